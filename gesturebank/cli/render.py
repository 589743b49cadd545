"""`gesturebank render`: the command's work (the CLI only parses options)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from gesturebank.config import MocapConfig, SynthConfig
from gesturebank.errors import InputError
from gesturebank.footage import SPEECH
from gesturebank.samples import default_samples_dir
from gesturebank.synth.take import Performer, render_take, rig_azimuths
from gesturebank.synth.truth import Truth


def render_command(
    bvh: Path,
    out: Path,
    *,
    synth: SynthConfig,
    mocap: MocapConfig,
    cameras: int | None,
    speech: Sequence[Path] | None,
) -> Truth:
    """Render `bvh` into `out`: `cameras` spread around the first azimuth when given; the
    sample speech (`fetch-samples`) unless `speech` files are given."""
    if not bvh.is_file():
        raise InputError(f"{bvh}: BVH file not found")
    if cameras is not None:
        azimuths = rig_azimuths(
            centre_deg=synth.azimuths_deg[0], count=cameras, spread_deg=synth.rig_spread_deg
        )
        synth = synth.model_copy(update={"azimuths_deg": azimuths})
    if not speech:
        samples = default_samples_dir()
        speech = [samples / rel for rel in SPEECH]
        missing = [p for p in speech if not p.is_file()]
        if missing:
            raise InputError(
                f"{missing[0]}: sample speech not found; run `gesturebank fetch-samples` or "
                "pass --speech"
            )
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: exists and is not a folder")
    return render_take([Performer(bvh)], out, config=synth, mocap=mocap, speech=speech)
