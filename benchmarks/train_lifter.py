"""Train the `learned` lifter (gesturebank.lift.learned) and score it on a tuning stretch.

Training data (issue 39): gesture motion made up on the fly over the upper body's range, many
proportions (lift.training.lifter_motion), and bvhtools' `test.bvh` outside 31–51 s (issue
30's acceptance stretch; test2/test3 and the renders are held back for evaluation) at 30 Hz,
played faster or slower, mirrored, re-proportioned, arms resampled (lifter_poses); seen by random
cameras as people film (seated to ceiling height, 1.2–6 m, 35–100°, the person anywhere in the
picture, lens distortion, the focal known or assumed) with BlazePose-like 2D error
(lift.training.lifter_views). The ONNX file and its sidecar JSON (architecture, data,
command, the table below) go to `--out`, by default the packaged
gesturebank/data/learned-lifter.onnx. Then the new model lifts test.bvh 21–31 s (a tuning
stretch, inside the training data) projected at 0/30/60° and 0° from 0.6 m above the chest and
prints its scores on Pepper.

    .venv/bin/python benchmarks/train_lifter.py [--steps N] [--out FILE] [--quick]

--quick: a few steps into a temporary folder, the same path (seconds; its numbers mean nothing).

The packaged model is not this recipe's yet: it was trained by this script as of commit dc8da7d
(test.bvh alone, 8,000 steps; its sidecar says so). This recipe's first net (4,000 steps, 40.6 min
on a busy machine) was measured against it through the whole build on held-out renders
(benchmarks/heldout.py, same run): calm motion arm 15.2–16.1° against 11.6–13.8°, hand equal
(5.3–5.7 cm), fast motion equal (22.4–23.0° against 22.6–23.6°); better on Pose2Sim
Demo_SinglePerson (26.7–32.8° against 31–39°) and from perfect 2D on held-out motion (arm
13.4–17.2° against 19.2–23.6°), worse on test.bvh. So it did not become the default.

--start-from FILE fine-tunes an exported net (its batch norms frozen). From the packaged net,
3,000 steps, --lr-start 3e-4 --gesture-share 0.4 (46 min on a busy machine), lifting the build's
BlazePose 2D of the held-out renders: better from 30° and 60° (arm 20.6 / 23.1° against 23.4 /
25.8°), on fast motion (30.1–30.3° against 31.4–31.7°) and on Pose2Sim (24.6–33.1° against
31.1–38.9°), worse at 0° and from above (19.9–20.2° against 16.1–19.2°) and on test.bvh 31–51 s
(9.0–9.8° against 7.9–8.5°): not packaged either (CHANGELOG, issue 39). These two paragraphs
quote Pose2Sim under the benchmarks' old angle difference, which read low by 2–12°.

With the torso's tilt as a target too (lifter_net.TILT_WEIGHT), 6,000 steps from scratch (31.6
min on a busy machine; `--steps 6000`), lifting the build's BlazePose 2D (heldout.py --floors
--onnx, processed): better at 30° and 60° (arm 15.9 / 16.9° against 19.4 / 19.6°) and on Pose2Sim
(31.1 / 29.5 / 29.7 / 31.7° per camera against 33.9 / 34.5 / 37.0 / 41.3°; `blazepose-world`
27.8 / 28.8 / 23.2 / 29.1°), worse at 0° and from above (16.3 / 15.8° against 14.1 / 13.8°), on
fast motion (23.9–24.2° against 23.5–23.6°) and on test.bvh 31–51 s (the lifter alone 13.9–15.9°
against 7.9–10.1°): not packaged (CHANGELOG, issue 39).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.camera_files import CameraGroup
from gesturebank.config import Config, LearnedConfig
from gesturebank.lift import TakeViews
from gesturebank.lift.learned import PACKAGED, LearnedLifter
from gesturebank.lift.learned import features as F
from gesturebank.lift.scoring import look_at, project_view, score_lift
from gesturebank.lift.training.lifter_net import (
    ARM_WEIGHT,
    TILT_WEIGHT,
    Architecture,
    Sampler,
    Schedule,
    TemporalLifterNet,
    export,
    train,
)
from gesturebank.mocap.bvh import read_bvh
from gesturebank.mocap.pose import body_axes, motion_pose
from gesturebank.samples import default_samples_dir

BVH = "bvhtools/testBvhFiles/test.bvh"
HELD_OUT_S = (31.0, 51.0)  # issue 30's acceptance stretch: never trained on
CHECK_S = (21.0, 31.0)  # a tuning stretch (trained on) for the table
MIN_STRETCH_S = 5.0
ELEVATED_M = 0.6  # the elevated check camera: above the chest, looking down at it


def training_takes(joints: np.ndarray, times: np.ndarray) -> list[np.ndarray]:
    """The parts of a take (T, 17, 3) outside HELD_OUT_S, each resampled to RATE_HZ."""
    parts = []
    for lo, hi in ((times[0], HELD_OUT_S[0]), (HELD_OUT_S[1], times[-1])):
        if hi - lo < MIN_STRETCH_S:
            continue
        grid = np.arange(lo, hi, 1 / F.RATE_HZ)
        parts.append(F.resample(joints, times, at=grid))
    return parts


def _started_from(path: Path) -> dict[str, object]:
    """What the fine-tuned net started from: its file and the sidecar's account of it."""
    meta = json.loads(path.with_suffix(".json").read_text(encoding="utf-8"))
    keys = ("trained_on", "command", "schedule", "minutes", "recipe", "started_from")
    return {"file": path.name, **{k: meta[k] for k in keys if k in meta}}


def check_table(path: Path, joints: np.ndarray, times: np.ndarray, config: Config) -> Table:
    """The model at `path` on CHECK_S of the take, true 2D at 0/30/60°."""
    pick = (times >= CHECK_S[0]) & (times < CHECK_S[1])
    truth, t = joints[pick], times[pick]
    front, left, up = body_axes(truth)
    neck, hips = truth[:, 5:7].mean(1), truth[:, 11:13].mean(1)
    chest = np.mean(0.75 * neck + 0.25 * hips, axis=0)
    lifter = LearnedLifter(learned=LearnedConfig(onnx_file=str(path)))
    table = Table(title=f"learned lifter, true 2D of test.bvh {CHECK_S[0]:g}–{CHECK_S[1]:g} s")
    for col in ("view", "arm MAE °", "wrong sign %", "hand cm", "frames/s"):
        table.add_column(col, justify="right")
    for azimuth, above in ((0.0, 0.0), (30.0, 0.0), (60.0, 0.0), (0.0, ELEVATED_M)):
        a = np.deg2rad(azimuth)
        eye = chest + 3.0 * (np.cos(a) * front + np.sin(a) * left) + above * up
        cam = look_at(eye=eye, target=chest, up=up, size=(1280, 720), fov_deg=60.0)
        start = time.perf_counter()
        lifted = lifter.lift(
            TakeViews.of(project_view(truth, cam, timestamps=t), CameraGroup([cam]))
        )
        fps = len(t) / (time.perf_counter() - start)
        score = score_lift(lifted, truth, camera=cam, retarget=config.retarget)
        view = f"{azimuth:g}°" + (f" +{above:g} m" if above else "")
        table.add_row(view, f"{score.arm_mae_deg:.1f}", f"{score.wrong_sign_pct:.0f}",
                      f"{score.hand_cm:.1f}", f"{fps:.0f}")  # fmt: skip
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a few steps, to a temporary file")
    parser.add_argument("--steps", type=int, default=Schedule.steps)
    parser.add_argument("--out", type=Path, default=PACKAGED, help="the ONNX file to write")
    parser.add_argument("--start-from", type=Path, help="an ONNX net to fine-tune (warm start)")
    parser.add_argument("--lr-start", type=float, default=Schedule.lr_start)
    parser.add_argument("--gesture-share", type=float, default=Sampler.gesture_share,
                        help="share of the stretches made up (the rest: test.bvh)")  # fmt: skip
    args = parser.parse_args()
    config = Config()
    whole = motion_pose(read_bvh(default_samples_dir() / BVH), config=config.mocap)[0]
    joints, times = whole.joints.astype(np.float64), whole.timestamps.astype(np.float64)
    takes = training_takes(joints, times)
    arch = Architecture()
    schedule = Schedule(steps=3 if args.quick else args.steps, lr_start=args.lr_start,
                        **({"batch": 4, "workers": 0} if args.quick else {}))  # fmt: skip
    console = Console(width=max(Console().width, 100))

    def log(step: int, loss: float, seconds: float) -> None:
        console.print(f"step {step}/{schedule.steps} · loss {loss:.4f} · {seconds:.0f} s")

    start = time.perf_counter()
    sampler = Sampler(takes, schedule.outputs + arch.receptive - 1,
                      gesture_share=args.gesture_share)  # fmt: skip

    def snapshot(step: int, net: TemporalLifterNet) -> None:  # a net to ship if time runs out
        if not args.quick:
            export(net, args.out.with_suffix(f".step{step}.onnx"), sidecar={"steps": step})

    net = train(lambda frames: replace(sampler, frames=frames), arch=arch, schedule=schedule,
                log=log, snapshot=snapshot, start_from=args.start_from)  # fmt: skip
    minutes = (time.perf_counter() - start) / 60
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "learned-lifter.onnx" if args.quick else args.out
        command = (
            f"python benchmarks/train_lifter.py --steps {schedule.steps} --lr-start "
            f"{schedule.lr_start:g} --gesture-share {sampler.gesture_share:g}"
            + (f" --start-from {args.start_from.name}" if args.start_from else "")
        )
        export(net, out, sidecar={
            "trained_on": f"{100 * sampler.gesture_share:.0f} % made-up gesture motion "
            "(gesturebank.lift.training.lifter_motion), the rest bvhtools "
            f"{BVH.split('/')[-1]} outside {HELD_OUT_S[0]:g}–{HELD_OUT_S[1]:g} s "
            f"({sum(len(t) for t in takes)} frames at {F.RATE_HZ:g} Hz; mirrored, other "
            "proportions and sampled arm motion); cameras as people film and BlazePose-like "
            "2D error (lift.training.lifter_views); never test2/test3",
            "command": command,
            "schedule": {k: getattr(schedule, k) for k in ("steps", "batch", "outputs",
                         "lr_start", "lr_end", "rng_seed", "torch_threads", "workers")},
            "loss": {"arm_weight": ARM_WEIGHT, "tilt_weight": TILT_WEIGHT},
            "minutes": round(minutes, 1),
            **({"started_from": _started_from(args.start_from)} if args.start_from else {}),
        })  # fmt: skip
        console.print(f"wrote {out} ({out.stat().st_size / 1e6:.2f} MB) after {minutes:.1f} min")
        console.print(check_table(out, joints, times, config))


if __name__ == "__main__":
    main()
