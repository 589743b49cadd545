"""`gesturebank render`: its options, and the command's work (`render_command`)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Literal

import typer

from gesturebank.cli.options import ConfigOption, SetOption, resolve_config
from gesturebank.cli.terminal import out, user_errors
from gesturebank.config import MocapConfig, SynthConfig
from gesturebank.errors import InputError

if TYPE_CHECKING:
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
    # imported here: the renderer (open3d, the retargeting) must not slow every command's start
    from gesturebank.footage import SPEECH
    from gesturebank.samples import default_samples_dir
    from gesturebank.synth.take import Performer, render_take, rig_azimuths

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


SynthLookOption = Literal["tshirt", "sleeves"]

_SYNTH = SynthConfig()  # the [synth] defaults, quoted in the render command's help


def _size(text: str | None) -> tuple[int, int] | None:
    """'1280x720' → (1280, 720)."""
    if text is None:
        return None
    w, sep, h = text.lower().partition("x")
    if not sep or not w.isdigit() or not h.isdigit():
        raise InputError(f"--size {text!r}: expected WIDTHxHEIGHT, e.g. 1280x720")
    return int(w), int(h)


def render(
    bvh: Annotated[Path, typer.Argument(help="The motion: a BVH file.")],
    *,
    out_dir: Annotated[Path, typer.Argument(help="Folder to write the take and its truth into.")],
    azimuth: Annotated[
        list[float] | None,
        typer.Option(
            help="Camera direction around the person, degrees (0 in front, positive towards "
            f"their left; repeat for a rig) [{_SYNTH.azimuths_deg}]."
        ),
    ] = None,
    cameras: Annotated[
        int | None,
        typer.Option(
            min=1,
            max=8,
            help=f"N cameras spread over {_SYNTH.rig_spread_deg:g}° (synth.rig_spread_deg) "
            "around --azimuth.",
        ),
    ] = None,
    elevation: Annotated[
        float | None,
        typer.Option(help=f"Camera height above the horizon, degrees [{_SYNTH.elevation_deg:g}]."),
    ] = None,
    distance: Annotated[
        float | None,
        typer.Option(
            help=f"Camera distance from the figure's chest, metres [{_SYNTH.distance_m:g}]."
        ),
    ] = None,
    fov: Annotated[
        float | None, typer.Option(help=f"Vertical field of view, degrees [{_SYNTH.fov_deg:g}].")
    ] = None,
    size: Annotated[
        str | None,
        typer.Option(
            help=f"Video size WIDTHxHEIGHT, px, even [{_SYNTH.width_px}x{_SYNTH.height_px}]."
        ),
    ] = None,
    fps: Annotated[
        float | None, typer.Option(help=f"Frame rate, frames/s [{_SYNTH.rate_fps:g}].")
    ] = None,
    start: Annotated[
        float | None, typer.Option(help=f"Start in the BVH, s [{_SYNTH.start_s:g}].")
    ] = None,
    seconds: Annotated[
        float | None, typer.Option(help="Length rendered, s [to the end of the BVH].")
    ] = None,
    look: Annotated[
        SynthLookOption | None,
        typer.Option(
            help="tshirt (short sleeves, light wall) or sleeves (long, brick wall) "
            f"[{_SYNTH.look}]."
        ),
    ] = None,
    speech: Annotated[
        list[Path] | None,
        typer.Option(help="Speech WAV (16 kHz mono; repeatable, looped) [the sample speech]."),
    ] = None,
    config_file: ConfigOption = None,
    sets: SetOption = None,
) -> None:
    """Render a BVH as video from known cameras, with speech, and write the exact truth beside
    it: OUT/videos/camNN.mp4, OUT/calibration.toml, OUT/speech.wav and OUT/truth.npz (3D joints,
    their projections, true Pepper angles). Two or more cameras make a multi-camera take that
    build-dataset reads.
    """
    from gesturebank.cli.render import render_command

    with user_errors():
        wh = _size(size)
        config = resolve_config(
            config_file=config_file,
            sets=sets,
            flags={
                "synth": {
                    "azimuths_deg": azimuth or None,
                    "elevation_deg": elevation,
                    "distance_m": distance,
                    "fov_deg": fov,
                    "width_px": wh and wh[0],
                    "height_px": wh and wh[1],
                    "rate_fps": fps,
                    "start_s": start,
                    "length_s": seconds,
                    "look": look,
                }
            },
        )
        truth = render_command(
            bvh, out_dir, synth=config.synth, mocap=config.mocap, cameras=cameras, speech=speech
        )
    out.print(
        f"{len(truth.times)} frames × {len(truth.cameras)} camera(s) written to {out_dir}",
        highlight=False,
        soft_wrap=True,
    )
