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

    .venv/bin/python benchmarks/pipeline_truth.py [--looks tshirt sleeves] [--azimuths 0 30 60]
    .venv/bin/python benchmarks/pipeline_truth.py --quick     # 3 s at 0°, 640×360, defaults
"""

from __future__ import annotations

import argparse
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.app.build import build_dataset
from gesturebank.config import Config, SynthConfig
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.process import process_angles
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
from gesturebank.synth.take import Performer, cached_render, render_cache
from gesturebank.synth.truth import Truth

BVH = "bvhtools/testBvhFiles/test.bvh"
START_S, LENGTH_S = 31.0, 20.0  # issue 30's acceptance stretch
QUICK_LENGTH_S, QUICK_SIZE = 3.0, (640, 360)
VIEWS_OFF = {"qc": {"max_facing_away_fraction": 1.0, "max_sideways_fraction": 1.0}}


def render(config: Config, *, azimuth: float, look: str, length_s: float,
           size: tuple[int, int]) -> Truth:  # fmt: skip
    samples = default_samples_dir()
    if not (samples / BVH).is_file():
        fetch_samples(samples)
    synth = SynthConfig.model_validate({
        "azimuths_deg": [azimuth], "start_s": START_S, "length_s": length_s, "look": look,
        "width_px": size[0], "height_px": size[1],
    })  # fmt: skip
    speech = [samples / rel for rel in SPEECH]
    return cached_render([Performer(samples / BVH)], config=synth, mocap=config.mocap,
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


@dataclass(frozen=True)
class Measured:
    kept_s: float
    reasons: list[str]
    wrong_sign_pct: float  # NaN: no clip kept
    expected_hand_cm: float  # the kept clips' expected_hand_error_cm, by duration; NaN: none
    pipeline: Scores | None  # None: no clip kept
    unlimited: Scores | None


def measure(truth: Truth, config: Config, out: Path) -> Measured:
    """Build the render's video into `out` and score its kept clips against both truths."""
    build_dataset(discover_takes(truth.videos[0].parent), truth.videos[0].parent, out, config)
    dataset = open_dataset(out)
    stored, pipeline_truth, unlimited = [], [], []
    deep, wrong = 0, 0
    expected = [(row.clip.metrics.get("expected_hand_error_cm", np.nan), row.clip.duration_s)
                for row in dataset.clips()]  # fmt: skip
    expected_cm = (
        float(np.average([e for e, _ in expected], weights=[d for _, d in expected]))
        if expected
        else float("nan")
    )
    for row in dataset.clips():
        clip = dataset.load(row.clip.clip_id)
        frames = np.round((clip.timestamps + clip.start_s - truth.times[0]) * truth.fps)
        frames = np.clip(frames.astype(int), 0, len(truth.times) - 1)
        signs = sign_errors(camera_axes(clip.pose3d), truth.joints3d[frames], truth.cameras[0])
        deep += sum(n for n, _ in signs.values())
        wrong += sum(w for _, w in signs.values())
        limited_truth, free_truth = truths(truth, clip.times + clip.start_s, config)
        stored.append(clip.angles.astype(np.float64))
        pipeline_truth.append(limited_truth)
        unlimited.append(free_truth)
    reasons = sorted({r for row in dataset.rows() for r in row.clip.qc_reasons})
    kept_s = sum(len(a) for a in stored) / config.processing.rate_hz
    wrong_pct = 100 * wrong / deep if deep else float("nan")
    if not stored:
        return Measured(kept_s, reasons, wrong_pct, expected_cm, None, None)
    mine = np.concatenate(stored)

    def scores(true: list[np.ndarray]) -> Scores:
        truth_angles = np.concatenate(true)
        per_joint, _, hand, head = score_angles(mine, truth_angles)
        return Scores(per_joint, hand, head, head_bias_deg(mine, truth_angles))

    return Measured(
        kept_s, reasons, wrong_pct, expected_cm, scores(pipeline_truth), scores(unlimited)
    )


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
    args = parser.parse_args()
    lifter = {"lifter": {"name": args.lifter}} if args.lifter else {}
    defaults = Config.model_validate(lifter)
    azimuths, looks = ([0.0], ["tshirt"]) if args.quick else (args.azimuths, args.looks)
    length = QUICK_LENGTH_S if args.quick else LENGTH_S
    size = QUICK_SIZE if args.quick else (defaults.synth.width_px, defaults.synth.height_px)
    table = Table(title=f"build-dataset ({defaults.detector.name}, {defaults.lifter.name}) on "
                  f"renders of test.bvh {START_S:g}–{START_S + length:g} s, kept clips against "
                  "the truth through the build's processing, and against the unlimited truth "
                  "(unl.)")  # fmt: skip
    for col in ("look", "view", "true away %", "QC", "kept s", "arm MAE °", "worst arm joint °",
                "hand cm", "expected hand cm", "wrong sign %", "head °", "HeadPitch/Yaw ° (bias)",
                "arm MAE ° (unl.)", "hand cm (unl.)", "QC reasons"):  # fmt: skip
        table.add_column(col, justify="right")
    configs = {"defaults": defaults}
    if not (args.quick or args.defaults_only):
        configs["views off"] = Config.model_validate({**VIEWS_OFF, **lifter})
    with tempfile.TemporaryDirectory(prefix="pipeline-truth-") as tmp:
        for look in looks:
            for azimuth in azimuths:
                truth = render(defaults, azimuth=azimuth, look=look, length_s=length, size=size)
                true_2d = truth.joints2d[0]
                away = facing_away(true_2d, np.ones(true_2d.shape[:2], dtype=bool)).mean()
                for qc, config in configs.items():
                    got = measure(truth, config, Path(tmp) / f"{look}-{azimuth:g}-{qc}")
                    first = (look, f"{azimuth:g}°", f"{100 * away:.0f}", qc)
                    kept = f"{got.kept_s:.1f} / {length:g}"
                    reasons = "; ".join(got.reasons) or "-"
                    if got.pipeline is None or got.unlimited is None:
                        table.add_row(*first, kept, *["-"] * 9, reasons)
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
                        f"{np.nanmean(got.unlimited.per_joint_deg[ARM_JOINTS]):.1f}",
                        f"{got.unlimited.hand_cm:.1f}", reasons,
                    )  # fmt: skip
    Console(width=max(Console().width, 160)).print(table)


if __name__ == "__main__":
    main()
