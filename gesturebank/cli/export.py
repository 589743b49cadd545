"""`gesturebank export SRC --format bvh|trc|csv|naoqi [--out F]`: the glue.

SRC is a dataset folder (every accepted clip, one file set per clip into the folder `--out`),
one clip's `.npz` inside a dataset, or an angle timeline (`robot.timeline`: the CSV `synthesize`
writes, an older dialect of it, or a record backend's JSONL; angles only: bvh, csv and naoqi).
The 3D joints are turned upright first (their mean hips → shoulders direction is up, their mean
facing direction forward), so viewers show the person standing.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
import typer

from gesturebank.app.export import uniform, upright
from gesturebank.cli.options import ConfigOption, ForceOption, SetOption, pick, resolve_config
from gesturebank.cli.terminal import out, user_errors
from gesturebank.config import Config
from gesturebank.errors import InputError
from gesturebank.fileio import keep_existing
from gesturebank.skeletons import COCO17

Format = Literal["bvh", "trc", "csv", "naoqi"]
SUFFIX = {"bvh": ".bvh", "trc": ".trc", "csv": ".angles.csv", "naoqi": ".naoqi.json"}
PERSON_SUFFIX = "_person.bvh"
TIMELINE_SUFFIXES = (".csv", ".jsonl")  # angle timelines: robot.timeline reads both


@dataclass(frozen=True)
class _Source:
    """What one export is made of: a name, angles on their clock, maybe the 3D joints."""

    name: str
    times: np.ndarray  # (N,) s (a clip: from its start; a timeline: on its audio's clock)
    angles: np.ndarray  # (N, 11) rad, NaN where unknown
    held: np.ndarray  # (N, 11) rad, finite (unknown angles hold the last known one)
    profile: str
    reach: str
    joints: np.ndarray | None = None  # (T, 17, 3) metres
    joint_times: np.ndarray | None = None  # (T,) s


def _clip_sources(src: Path) -> list[_Source]:
    from gesturebank import datasets
    from gesturebank.robot.timeline import hold, reach_of

    if src.is_dir():
        data = datasets.open(src)
        ids = data.clip_ids("accepted")
        if not ids:
            raise InputError(f"{src}: no accepted clip to export")
    else:
        root = src.parents[2] if len(src.parents) > 2 else src.parent
        data = datasets.open(root)
        ids = [src.stem]
    profile, reach = data.info.robot_profile, reach_of(data.info.config)
    out = []
    for clip_id in ids:
        clip = data.load(clip_id)
        out.append(
            _Source(
                clip_id,
                clip.times,
                clip.angles,
                hold(clip.angles),
                profile,
                reach,
                np.asarray(clip.pose3d.joints, np.float64),
                clip.pose3d.timestamps,
            )
        )
    return out


def _sources(src: Path, config: Config) -> list[_Source]:
    if src.is_dir() or src.suffix == ".npz":
        if not (src.exists()):
            raise InputError(f"{src}: no such file or folder")
        return _clip_sources(src)
    if src.suffix.lower() in TIMELINE_SUFFIXES:
        from gesturebank.robot.timeline import reach_of, read_timeline

        line = read_timeline(src)
        profile = line.profile or config.robot.profile
        reach = line.reach or reach_of(config)
        return [_Source(src.stem, line.times, line.masked, line.angles, profile, reach)]
    raise InputError(
        f"{src}: expected a dataset folder, a clip .npz or an angle timeline (.csv, .jsonl)"
    )


def _write(
    source: _Source, fmt: Format, out: Path, config: Config, audio: Path | None = None
) -> list[Path]:
    from gesturebank.mocap.bvh import write_bvh
    from gesturebank.robot import pepper, safety
    from gesturebank.robot.timeline import Timeline

    if fmt == "csv":
        from gesturebank.robot.timeline import write_timeline

        line = Timeline.of(source.times, source.angles, profile=source.profile, reach=source.reach)
        return [write_timeline(out, line)]
    if fmt == "trc":
        from gesturebank.export.trc import write_trc

        if source.joints is None or source.joint_times is None:
            raise InputError(f"{source.name}: an angles CSV has no 3D joints; trc needs a clip")
        _, joints, rate = uniform(source.joint_times, upright(source.joints, layout="opensim"))
        return [write_trc(out, markers=joints, names=COCO17.joints, rate_hz=rate)]
    profile = pepper.load_profile(source.profile)
    safe = safety.safe_angles(
        Timeline.of(source.times, source.held),
        safety.speed_profile(profile, config.playback.max_speed_fraction),
    )
    if fmt == "naoqi":
        from gesturebank.export.naoqi import write_naoqi

        return list(
            write_naoqi(
                out,
                times=source.times,
                angles=safe,
                lead_s=config.playback.start_s,
                profile=source.profile,
                audio=audio,
            )
        )
    from gesturebank.export.pepper_bvh import pepper_motion
    from gesturebank.export.person_bvh import person_motion

    _, angles, rate = uniform(source.times, safe)
    motion = pepper_motion(
        angles=angles, frame_time=1.0 / rate, kinematics=config.retarget.kinematics
    )
    paths = [write_bvh(out, motion)]
    if source.joints is not None and source.joint_times is not None:
        _, joints, jrate = uniform(source.joint_times, upright(source.joints, layout="bvh"))
        person = out.with_name(out.name.removesuffix(".bvh") + PERSON_SUFFIX)
        paths.append(write_bvh(person, person_motion(joints=joints, frame_time=1.0 / jrate)))
    return paths


def export_command(
    *,
    src: Path,
    fmt: Format,
    out: Path | None,
    config: Config,
    audio: Path | None = None,
    force: bool = True,
) -> list[Path]:
    """Export `src` as `fmt` into `out` (a file for one clip or CSV; a folder for a dataset;
    default: `<name><suffix>` in the working directory, or `<dataset>-<fmt>/`). Returns the
    files written. `audio` (naoqi, one clip or CSV): speech the script plays on the robot.
    `force` False: an InputError when a target exists (`fileio.keep_existing`)."""
    if audio is not None and (fmt != "naoqi" or src.is_dir()):
        raise InputError(f"{audio}: --audio goes with --format naoqi of one clip or angles CSV")
    sources = _sources(src, config)
    if src.is_dir():
        folder = out if out is not None else Path(f"{src.resolve().name}-{fmt}")
        targets = [folder / f"{s.name}{SUFFIX[fmt]}" for s in sources]
    else:
        targets = [out if out is not None else Path(f"{sources[0].name}{SUFFIX[fmt]}")]
    if any(t.resolve() == src.resolve() for t in targets):
        raise InputError(f"{src}: --out would overwrite the input; name another file")
    keep_existing(targets, force=force)
    written: list[Path] = []
    for source, target in zip(sources, targets, strict=True):
        written += _write(source, fmt, target, config, audio)
    return written


def export(
    src: Annotated[
        Path,
        typer.Argument(
            help="A dataset folder (every accepted clip), one clip's .npz in a dataset, or an "
            "angle timeline (.csv from synthesize, export or record; a record .jsonl)."
        ),
    ],
    *,
    fmt: Annotated[
        Format,
        typer.Option(
            "--format",
            parser=pick(Format),
            help="bvh: Pepper's upper body (and, for a clip, the person as NAME_person.bvh); "
            "trc: the clip's 3D joints (OpenSim/Pose2Sim markers, m); csv: the angle timeline "
            "replay reads (profile, unit, reach in a # line; masked angles empty); naoqi: "
            "ALMotion.angleInterpolation arguments (.json) and a script.",
        ),
    ],
    out_path: Annotated[
        Path | None,
        typer.Option(
            "--out",
            help="File to write (a folder for a dataset); default: NAME and the format's "
            "suffix (.bvh, .trc, .angles.csv, .naoqi.json) here, or the folder DATASET-FORMAT.",
        ),
    ] = None,
    audio: Annotated[
        Path | None,
        typer.Option(
            help="naoqi: speech the script plays on the robot, in step with the motion "
            "(one clip or angles CSV)."
        ),
    ] = None,
    config_file: ConfigOption = None,
    sets: SetOption = None,
    force: ForceOption = False,
) -> None:
    """Write clips or angles in other tools' formats (Blender, the GENEA visualiser, OpenSim,
    Pose2Sim, Choregraphe, NAOqi scripts).

    The robot's angles are exported clamped and speed-limited as `replay` plays them; bvh and
    trc joints are in metres (BVH offsets in centimetres), upright (y up).
    """
    from gesturebank.cli.export import export_command

    with user_errors():
        config = resolve_config(config_file=config_file, sets=sets, flags={})
        written = export_command(
            src=src, fmt=fmt, out=out_path, config=config, audio=audio, force=force
        )
    for path in written:
        out.print(f"wrote {path}", highlight=False, soft_wrap=True)
