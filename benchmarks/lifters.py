"""Monocular lifters against the multi-view reference, in Pepper angles, on the Pose2Sim demo.

The Pose2Sim Demo_SinglePerson is one person seen by 4 calibrated, synchronised cameras. The
multi-view lifter (its own Qualisys calibration, BlazePose 2D on every camera) gives the reference
3D pose; each monocular lifter then works from each single camera's 2D, and the table shows the
mean absolute error of the 11 Pepper angles against the reference (degrees, over the frames where
both are known). Retargeting is invariant to the frame, scale and position of its input, so the
lifters' different output frames compare directly.

    .venv/bin/python benchmarks/lifters.py [--quick]

--quick: the first 0.3 s of every camera (a few seconds), to check that the script runs.

No target yet: this is the baseline later lifters must beat.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.config import Config
from gesturebank.datasets.takes import find_calibration
from gesturebank.extract.pipeline import extract_take
from gesturebank.lift import LIFTERS
from gesturebank.lift.multiview.cameras import CameraGroup
from gesturebank.lift.multiview.lifter import MultiviewLifter, match_videos
from gesturebank.robot.pepper import JOINTS
from gesturebank.robot.retarget import pepper_angles
from gesturebank.samples import default_samples_dir, fetch_samples

MONOCULAR = ("blazepose-world", "geometric")
QUICK_S = 0.3  # --quick: seconds of each camera (about 9 frames at the default 30 fps)


def angle_error_deg(angles: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, float]:
    """Per-joint mean |error| (11,) in degrees over frames where both are finite, and the share
    of reference frames the lifter covers."""
    both = np.isfinite(angles) & np.isfinite(reference)
    diff = np.where(both, np.abs(angles - reference), np.nan)
    diff = np.minimum(diff, 2 * np.pi - diff)  # angles are periodic
    with warnings.catch_warnings():  # a joint never seen by both gives NaN, and says so
        warnings.simplefilter("ignore", RuntimeWarning)
        per_joint = np.rad2deg(np.nanmean(diff, axis=0))
    covered = float(both.all(axis=1).sum() / max(1, np.isfinite(reference).all(axis=1).sum()))
    return per_joint, covered


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help=f"the first {QUICK_S} s only")
    args = parser.parse_args()
    samples = default_samples_dir()
    root = samples / "pose2sim" / "Demo_SinglePerson"
    if not (root / "videos").is_dir():  # fetching re-checks every sample's checksum: only if needed
        fetch_samples(samples)
    config = Config()
    if args.quick:
        config.video.end_s = QUICK_S
    cams = CameraGroup.load(find_calibration(root))
    videos = match_videos(cams, sorted((root / "videos").glob("*.mp4")))
    poses = [extract_take(v, config, with_audio=False).tracked.pose for v in videos]
    reference = pepper_angles(MultiviewLifter(config, cameras=cams).lift(poses))

    span = f", first {QUICK_S} s" if args.quick else ""
    table = Table(
        title=f"Pepper-angle error vs multi-view (degrees), Pose2Sim Demo_SinglePerson{span}"
    )
    for col in ("lifter", "camera", *JOINTS, "mean", "frames"):
        table.add_column(col, justify="right")
    means: dict[str, list[float]] = {name: [] for name in MONOCULAR}
    for name in MONOCULAR:
        lifter = LIFTERS.create(name, config)
        for video, pose2d in zip(videos, poses, strict=True):
            per_joint, covered = angle_error_deg(pepper_angles(lifter.lift(pose2d)), reference)
            mean = float(np.nanmean(per_joint))
            means[name].append(mean)
            table.add_row(
                name,
                video.stem,
                *(f"{v:.0f}" for v in per_joint),
                f"{mean:.1f}",
                f"{100 * covered:.0f} %",
            )
    Console(width=max(Console().width, 150)).print(table)  # 15 columns: keep them readable
    for name, values in means.items():
        print(f"{name}: mean over cameras {np.mean(values):.1f} deg")


if __name__ == "__main__":
    main()
