"""The whole pipeline against motion-capture truth: `build-dataset` on rendered takes, and the
kept clips' stored angles against what the person did over the same times (issue 30, item 2).

Each take is `test.bvh` 31–51 s (issue 30's acceptance stretch) rendered by `gesturebank.synth`
(cached by checksum) from one camera 3 m away, turned 0°, 30° and 60° from the front, in both
looks; the build runs with its defaults (detector, lifter, QC), its detections cached like any
build's. Two truths, both on each clip's own 100 Hz clock:

- pipeline truth: the true Pepper angles (`truth.npz` `angles`) through the build's own processing
  (`datasets.process.process_angles`: continuous, low-passed, the same reach mode and speed
  limit), i.e. what a perfect detector and lifter would have stored;
- unlimited truth: the same, low-passed and continuous but not brought into Pepper's reach.

Each take is built twice: with the defaults, and with QC's view limits off
(`qc.max_facing_away_fraction` and `qc.max_sideways_fraction` at 1), since the person of this
stretch turns round: "true away %" is QC's own facing-away rule on the true 2D joints.

Scored with `lift.scoring.score_angles`: arm-angle MAE over the eight arm joints, the worst arm
joint, Pepper-FK hand error (cm) and head direction error (°); "wrong sign %" is the kept clips'
stored 3D against the true joints of the same video frames (`lift.scoring.sign_errors`: arm
bones clearly towards or away from the camera, pooled, lifted the other way); "expected hand
cm" is what the kept clips' depth confidence predicts (`expected_hand_error_cm`, by duration).
"kept" is the accepted clips' seconds of the rendered seconds; a rejected take names QC's
reasons.

The head (issue 40): "head °" is the head direction error (HeadPitch and HeadYaw together),
"HeadPitch/Yaw ° (bias)" their mean errors and mean signed errors; "head from" splits the kept
clips' 100 Hz frames by the source of their head (`clip.head_source`: the face mesh, the body's
face keypoints): the share of each and its head error, so the mesh, the fallback and the chosen
mix are each scored. `--head-source body` builds with the body's keypoints only (the head
before issue 40); `--every-clip` scores the clips QC rejected too (side views, arms at a limit:
their heads are still measured). `--cameras N` renders each view as a calibrated rig of N cameras
spread over `[synth] rig_spread_deg` around its azimuth and builds it as one multi-camera take
(the `multiview` lifter; the head from every camera's face, `datasets.head.rig_head`).

    .venv/bin/python benchmarks/pipeline_truth.py [--looks tshirt sleeves] [--azimuths 0 30 60]
    .venv/bin/python benchmarks/pipeline_truth.py --bvh test2.bvh test3.bvh --start 0 \
        --length 20 --azimuths 0 30 60 90 --elevations 0 30 --looks tshirt --defaults-only
    .venv/bin/python benchmarks/pipeline_truth.py --quick     # 3 s at 0°, 640×360, defaults
"""

from __future__ import annotations

import argparse
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.app.build import build_dataset
from gesturebank.clip import HEAD_SOURCES, Clip
from gesturebank.config import Config, SynthConfig
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.process import process_angles
from gesturebank.datasets.store import Status
from gesturebank.datasets.takes import discover_takes
from gesturebank.footage import SPEECH
from gesturebank.lift import LIFTERS
from gesturebank.lift.scoring import (
    ARM_JOINTS,
    camera_axes,
    head_bias_deg,
    score_angles,
    sign_errors,
)
from gesturebank.qc.metrics import facing_away
from gesturebank.robot import pepper
from gesturebank.robot.pepper import JOINTS
from gesturebank.samples import default_samples_dir, fetch_samples
from gesturebank.synth.take import Performer, cached_render, render_cache, rig_azimuths
from gesturebank.synth.truth import CALIBRATION, VIDEOS, Truth
from gesturebank.synth.truth import SPEECH as SPEECH_WAV

BVH_DIR = "bvhtools/testBvhFiles"
START_S, LENGTH_S = 31.0, 20.0  # issue 30's acceptance stretch
QUICK_LENGTH_S, QUICK_SIZE = 3.0, (640, 360)
VIEWS_OFF = {"qc": {"max_facing_away_fraction": 1.0, "max_sideways_fraction": 1.0}}


def render(config: Config, *, azimuth: float, look: str, length_s: float,
           size: tuple[int, int], bvh: str = "test.bvh", start_s: float = START_S,
           elevation: float = 0.0, cameras: int = 1) -> Truth:  # fmt: skip
    samples = default_samples_dir()
    path = samples / BVH_DIR / bvh
    if not path.is_file():
        fetch_samples(samples)
    synth = SynthConfig.model_validate({
        "azimuths_deg": rig_azimuths(centre_deg=azimuth, count=cameras,
                                     spread_deg=config.synth.rig_spread_deg),
        "start_s": start_s, "length_s": length_s, "look": look,
        "width_px": size[0], "height_px": size[1], "elevation_deg": elevation,
    })  # fmt: skip
    speech = [samples / rel for rel in SPEECH]
    return cached_render([Performer(path)], config=synth, mocap=config.mocap,
                         speech=speech, cache=render_cache(samples))  # fmt: skip


def truths(truth: Truth, clock: np.ndarray, config: Config) -> tuple[np.ndarray, np.ndarray]:
    """(pipeline truth, unlimited truth), each (N, 11) rad on `clock` (s in the video)."""
    processed = process_angles(
        raw=truth.angles, timestamps=truth.times, clock=clock, processing=config.processing,
        retarget=config.retarget, profile=pepper.load_profile(config.robot.profile),
    )  # fmt: skip
    return processed.angles.astype(np.float64), processed.unlimited


@dataclass(frozen=True)
class Scores:
    """Kept clips against one truth: per-joint MAE (11,) °, FK hand error cm, head error °,
    HeadPitch and HeadYaw mean signed error °."""

    per_joint_deg: np.ndarray
    hand_cm: float
    head_deg: float
    head_bias: tuple[float, float]
    head_by_source: dict[str, tuple[float, float]]  # source → (share of frames, head error °)


@dataclass(frozen=True)
class Measured:
    kept_s: float
    reasons: list[str]
    wrong_sign_pct: float  # NaN: no clip kept
    expected_hand_cm: float  # the kept clips' expected_hand_error_cm, by duration; NaN: none
    pipeline: Scores | None  # None: no clip kept
    unlimited: Scores | None


def measure(truth: Truth, config: Config, out: Path, *, every_clip: bool = False) -> Measured:
    """Build the render's video into `out` and score its kept clips (`every_clip`: every clip
    it made, QC's verdict aside) against both truths."""
    status: Status | None = None if every_clip else "accepted"
    videos = truth.videos[0].parent
    if len(truth.videos) > 1:  # a calibrated rig: one multi-camera take (its files linked)
        take = out.parent / f"{out.name}-take" / "rig"
        (take / VIDEOS).mkdir(parents=True)
        for video in truth.videos:
            (take / VIDEOS / video.name).symlink_to(video)
        for name in (CALIBRATION, SPEECH_WAV):
            (take / name).symlink_to(truth.folder / name)
        videos = take.parent
    build_dataset(discover_takes(videos), videos_dir=videos, out=out, config=config)
    dataset = open_dataset(out)
    stored, pipeline_truth, unlimited, sources = [], [], [], []
    deep, wrong = 0, 0
    expected = [(row.clip.metrics.get("expected_hand_error_cm", np.nan), row.clip.duration_s)
                for row in dataset.clips(status)]  # fmt: skip
    expected_cm = (
        float(np.average([e for e, _ in expected], weights=[d for _, d in expected]))
        if expected
        else float("nan")
    )
    for row in dataset.clips(status):
        clip = dataset.load(row.clip.clip_id)
        frames = np.round((clip.timestamps + clip.start_s - truth.times[0]) * truth.fps)
        frames = np.clip(frames.astype(int), 0, len(truth.times) - 1)
        lifted = (
            truth.cameras[0].to_camera(clip.pose3d.joints.astype(np.float64))
            if clip.pose3d.frame == "world"  # a rig's triangulated joints
            else camera_axes(clip.pose3d)
        )
        signs = sign_errors(lifted, truth.joints3d[frames], camera=truth.cameras[0])
        deep += sum(n for n, _ in signs.values())
        wrong += sum(w for _, w in signs.values())
        limited_truth, free_truth = truths(truth, clip.times + clip.start_s, config)
        stored.append(clip.angles.astype(np.float64))
        sources.append(head_source_at(clip))
        pipeline_truth.append(limited_truth)
        unlimited.append(free_truth)
    reasons = sorted({r for row in dataset.rows() for r in row.clip.qc_reasons})
    kept_s = sum(len(a) for a in stored) / config.processing.rate_hz
    wrong_pct = 100 * wrong / deep if deep else float("nan")
    if not stored:
        return Measured(kept_s, reasons, wrong_pct, expected_cm, None, None)
    mine = np.concatenate(stored)

    source = np.concatenate(sources)

    def scores(true: list[np.ndarray]) -> Scores:
        truth_angles = np.concatenate(true)
        per_joint, _, hand, head = score_angles(mine, truth_angles)
        by_source = {}
        for code, name in enumerate(HEAD_SOURCES):
            rows = source == code
            if code and rows.any():
                share = float(rows.mean())
                by_source[name] = (share, score_angles(mine[rows], truth_angles[rows])[3])
        return Scores(per_joint, hand, head, head_bias_deg(mine, truth_angles), by_source)

    return Measured(
        kept_s, reasons, wrong_pct, expected_cm, scores(pipeline_truth), scores(unlimited)
    )


def head_source_at(clip: Clip) -> np.ndarray:
    """(N,) the head's source (`clip.HEAD_SOURCES` code) of the video frame nearest each of the
    clip's 100 Hz times."""
    k = np.searchsorted(clip.timestamps, clip.times)
    k = np.clip(k, 1, max(1, len(clip.timestamps) - 1))
    nearer = np.abs(clip.timestamps[k - 1] - clip.times) <= np.abs(clip.timestamps[k] - clip.times)
    k = np.where(nearer, k - 1, k) if len(clip.timestamps) > 1 else np.zeros_like(k)
    return np.asarray(clip.head_source)[k]


def main() -> None:
    parser = argparse.ArgumentParser(
        description="The whole pipeline against motion-capture truth: build-dataset on rendered "
        "takes, the kept clips against what the person did."
    )
    parser.add_argument("--azimuths", type=float, nargs="+", default=[0.0, 30.0, 60.0])
    parser.add_argument("--looks", nargs="+", default=["tshirt", "sleeves"])
    parser.add_argument("--lifter", choices=[n for n in LIFTERS.names() if n != "multiview"],
                        help="the build's lifter (default: the configuration's)")  # fmt: skip
    parser.add_argument("--defaults-only", action="store_true",
                        help="skip the second build with QC's view limits off")  # fmt: skip
    parser.add_argument("--quick", action="store_true", help="3 s at 0°, small, one look")
    parser.add_argument(
        "--every-clip",
        action="store_true",
        help="score every clip the build made, QC's verdict aside (the head where QC rejects "
        "the view or the arms); 'kept s' then counts them all",
    )
    parser.add_argument(
        "--bvh",
        nargs="+",
        default=["test.bvh"],
        help="motions of bvhtools' testBvhFiles (test2.bvh, test3.bvh: held out)",
    )
    parser.add_argument("--start", type=float, default=START_S, help="where in the BVH, s")
    parser.add_argument("--length", type=float, help=f"seconds rendered (default {LENGTH_S:g})")
    parser.add_argument(
        "--elevations",
        type=float,
        nargs="+",
        default=[0.0],
        help="camera heights, degrees above the horizon",
    )
    parser.add_argument(
        "--cameras",
        type=int,
        default=1,
        help="cameras per view: more makes a calibrated rig spread over [synth] rig_spread_deg "
        "around each azimuth, built as one multi-camera take (the multiview lifter)",
    )
    parser.add_argument(
        "--head-source",
        choices=["face", "body"],
        help="retarget.head_source of the build (default: the configuration's)",
    )
    args = parser.parse_args()
    lifter: dict[str, Any] = {"lifter": {"name": args.lifter}} if args.lifter else {}
    if args.head_source:
        lifter["retarget"] = {"head_source": args.head_source}
    defaults = Config.model_validate(lifter)
    azimuths, looks = ([0.0], ["tshirt"]) if args.quick else (args.azimuths, args.looks)
    length = QUICK_LENGTH_S if args.quick else (args.length or LENGTH_S)
    size = QUICK_SIZE if args.quick else (defaults.synth.width_px, defaults.synth.height_px)
    table = Table(title=f"build-dataset ({defaults.detector.name}, {defaults.lifter.name}, head "
                  f"from {defaults.retarget.head_source}) on renders of {' '.join(args.bvh)} "
                  f"{args.start:g}–{args.start + length:g} s, kept clips against "
                  "the truth through the build's processing, and against the unlimited truth "
                  "(unl.)")  # fmt: skip
    for col in ("motion", "look", "view", "true away %", "QC", "kept s", "arm MAE °",
                "worst arm joint °", "hand cm", "expected hand cm", "wrong sign %", "head °",
                "HeadPitch/Yaw ° (bias)", "head P/Y mean °", "head from: share % head °",
                "arm MAE ° (unl.)", "hand cm (unl.)", "QC reasons"):  # fmt: skip
        table.add_column(col, justify="right")
    configs = {"defaults": defaults}
    if not (args.quick or args.defaults_only):
        configs["views off"] = Config.model_validate({**VIEWS_OFF, **lifter})
    with tempfile.TemporaryDirectory(prefix="pipeline-truth-") as tmp:
        views = [(b, look, az, el) for b in args.bvh for look in looks for el in args.elevations
                 for az in azimuths]  # fmt: skip
        for bvh, look, azimuth, elevation in views:
            truth = render(defaults, azimuth=azimuth, look=look, length_s=length, size=size,
                           bvh=bvh, start_s=args.start, elevation=elevation,
                           cameras=args.cameras)  # fmt: skip
            true_2d = truth.joints2d[0]
            away = facing_away(true_2d, np.ones(true_2d.shape[:2], dtype=bool)).mean()
            for qc, config in configs.items():
                name = f"{bvh}-{look}-{azimuth:g}-{elevation:g}-{qc}"
                got = measure(truth, config, Path(tmp) / name, every_clip=args.every_clip)
                view = f"{azimuth:g}°" + (f" ↑{elevation:g}°" if elevation else "")
                view += f" ×{args.cameras}" if args.cameras > 1 else ""
                first = (bvh, look, view, f"{100 * away:.0f}", qc)
                kept = f"{got.kept_s:.1f} / {length:g}"
                reasons = "; ".join(got.reasons) or "-"
                if got.pipeline is None or got.unlimited is None:
                    table.add_row(*first, kept, *["-"] * 11, reasons)
                    continue
                arm = got.pipeline.per_joint_deg[ARM_JOINTS]
                worst = int(np.nanargmax(arm))
                table.add_row(
                    *first, kept, f"{np.nanmean(arm):.1f}",
                    f"{JOINTS[ARM_JOINTS[worst]]} {arm[worst]:.0f}",
                    f"{got.pipeline.hand_cm:.1f}", f"{got.expected_hand_cm:.1f}",
                    f"{got.wrong_sign_pct:.0f}", f"{got.pipeline.head_deg:.1f}",
                    f"{got.pipeline.per_joint_deg[0]:.0f}/{got.pipeline.per_joint_deg[1]:.0f} "
                    f"({got.pipeline.head_bias[0]:+.0f}/{got.pipeline.head_bias[1]:+.0f})",
                    f"{np.mean(got.pipeline.per_joint_deg[:2]):.1f}",
                    " ".join(f"{k} {100 * share:.0f} {deg:.1f}" for k, (share, deg)
                             in got.pipeline.head_by_source.items()) or "-",
                    f"{np.nanmean(got.unlimited.per_joint_deg[ARM_JOINTS]):.1f}",
                    f"{got.unlimited.hand_cm:.1f}", reasons,
                )  # fmt: skip
    Console(width=max(Console().width, 160)).print(table)


if __name__ == "__main__":
    main()
