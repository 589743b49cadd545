"""Monocular lifters against the multi-view reference, in Pepper angles, on the Pose2Sim demo.

The Pose2Sim Demo_SinglePerson is one person seen by 4 calibrated, synchronised cameras. The
multi-view lifter (its own Qualisys calibration, BlazePose 2D on every camera) gives the reference
3D pose; each monocular lifter then works from each single camera's 2D, and the table shows the
mean absolute error of the 11 Pepper angles against the reference (degrees, over the frames where
both are known). Retargeting is invariant to the frame, scale and position of its input, so the
lifters' different output frames compare directly.

    .venv/bin/python benchmarks/lifters.py

No target yet: this is the baseline later lifters must beat.
"""

from __future__ import annotations

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.config import Config
from gesturebank.extract.pipeline import extract_take
from gesturebank.lift import LIFTERS
from gesturebank.lift.multiview.cameras import CameraGroup
from gesturebank.lift.multiview.lifter import MultiviewLifter, find_calibration, match_videos
from gesturebank.robot.pepper import JOINTS
from gesturebank.robot.retarget import pepper_angles
from gesturebank.samples import default_samples_dir, fetch_samples

MONOCULAR = ("blazepose-world", "geometric")


def angle_error_deg(angles: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, float]:
    """Per-joint mean |error| (11,) in degrees over frames where both are finite, and the share
    of reference frames the lifter covers."""
    both = np.isfinite(angles) & np.isfinite(reference)
    diff = np.where(both, np.abs(angles - reference), np.nan)
    diff = np.minimum(diff, 2 * np.pi - diff)  # angles are periodic
    with np.errstate(invalid="ignore"):
        per_joint = np.rad2deg(np.nanmean(diff, axis=0))
    covered = float(both.all(axis=1).sum() / max(1, np.isfinite(reference).all(axis=1).sum()))
    return per_joint, covered


def main() -> None:
    samples = default_samples_dir()
    fetch_samples(samples)
    root = samples / "pose2sim" / "Demo_SinglePerson"
    config = Config()
    cams = CameraGroup.load(find_calibration(root))
    videos = match_videos(cams, sorted((root / "videos").glob("*.mp4")))
    poses = [extract_take(v, config, with_audio=False)[0] for v in videos]
    reference = pepper_angles(MultiviewLifter(config, cameras=cams).lift(poses))

    table = Table(title="Pepper-angle error vs multi-view (degrees), Pose2Sim Demo_SinglePerson")
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
    Console().print(table)
    for name, values in means.items():
        print(f"{name}: mean over cameras {np.mean(values):.1f} deg")


if __name__ == "__main__":
    main()
