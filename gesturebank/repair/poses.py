"""The repair of one take's main speaker, as `Pose2D` (swaps, outliers, gaps; its world
coordinates alike) and as `Pose3D` (outliers and gaps), and what it changed (`RepairReport`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from gesturebank.config import RepairConfig
from gesturebank.poses import Pose2D, Pose3D
from gesturebank.repair.keypoints import Bools, refill, replace_outliers, take_outliers
from gesturebank.repair.swaps import repair_swaps
from gesturebank.skeletons import COCO17, get_skeleton


@dataclass(frozen=True, eq=False)
class RepairReport:
    """What the repair of one take changed.

    outliers:       keypoint samples the Hampel filter flagged (in 2D or world) and replaced by
                    interpolation (left NaN if they sit in a gap longer than max_gap_s).
    filled:         keypoint samples missing in the input and filled by interpolation (gaps
                    only; the refilled outliers are not counted again).
    swapped_frames: frames in which some body group's left/right labels were exchanged back
                    (frames inside such a run where the group was unseen count too).
    swap_runs:      runs of consecutive such frames.
    repaired:       (T, K) bool, keypoints whose position or confidence any repair changed.
    """

    outliers: int
    filled: int
    swapped_frames: int
    swap_runs: int
    repaired: Bools

    def counts(self) -> dict[str, int]:
        """The counts, for the manifest's `repairs` column."""
        return {
            "outliers": self.outliers,
            "filled": self.filled,
            "swapped_frames": self.swapped_frames,
            "swap_runs": self.swap_runs,
        }


def validity(pose: Pose2D, *, visible_confidence: float) -> Bools:
    """(T, K) bool: the keypoint was seen: it has a position inside the image and confidence
    >= `visible_confidence`.

    A keypoint outside the image is the detector's extrapolation, however confident (BlazePose
    places the hips and elbows of a head-and-shoulders shot below the frame with visibility
    near 1): the angles and bones that need it are not measured from a guess."""
    w, h = pose.image_size
    x, y = pose.xy[..., 0], pose.xy[..., 1]
    with np.errstate(invalid="ignore"):
        inside = (x >= 0) & (x <= w) & (y >= 0) & (y <= h)
        return inside & (pose.confidence >= visible_confidence)


def _runs_of(mask: Bools) -> int:
    return int(np.sum(np.diff(np.concatenate([[0], mask.astype(np.int8)])) == 1))


def _changed(before: np.ndarray, after: np.ndarray) -> Bools:
    """(T, K) True where any channel of `(T, K, C)` differs (NaN equal to NaN)."""
    same = (before == after) | (np.isnan(before) & np.isnan(after))
    return ~same.all(axis=-1)


def repair_pose2d(pose: Pose2D, *, config: RepairConfig) -> tuple[Pose2D, RepairReport]:
    """Repaired copy of a take's main speaker `pose` and what was done (`gesturebank.repair`).

    `pose.world`, when present, is repaired with the 2D keypoints: the same swap flips, and a
    keypoint that is an outlier in 2D or in world is replaced in both.
    """
    skeleton = get_skeleton(pose.skeleton)
    ts = pose.timestamps
    kp = pose.keypoints.astype(np.float64)
    world = None if pose.world is None else pose.world.astype(np.float64)
    flipped = np.zeros(len(kp), dtype=bool)
    if config.swaps:
        kp, world, flipped = repair_swaps(
            kp, world, timestamps=ts, skeleton=skeleton, config=config
        )

    outliers = take_outliers(kp[..., :2], ts, skeleton=skeleton, config=config)
    if world is not None:
        outliers |= take_outliers(world, ts, skeleton=skeleton, config=config)
    xy, conf, gaps = refill(
        kp[..., :2], kp[..., 2], outliers=outliers, timestamps=ts, max_gap_s=config.max_gap_s
    )
    out_kp = np.concatenate([xy, conf[..., None]], axis=-1)
    if world is not None:
        world, world_filled = replace_outliers(
            world, outliers, timestamps=ts, max_gap_s=config.max_gap_s
        )
        gaps |= world_filled & ~outliers

    repaired = _changed(pose.keypoints.astype(np.float64), out_kp)
    if world is not None and pose.world is not None:
        repaired |= _changed(pose.world.astype(np.float64), world)
    report = RepairReport(
        outliers=int(outliers.sum()),
        filled=int(gaps.sum()),
        swapped_frames=int(flipped.sum()),
        swap_runs=_runs_of(flipped),
        repaired=repaired,
    )
    out = replace(
        pose,
        keypoints=out_kp.astype(np.float32),
        world=None if world is None else world.astype(np.float32),
    )
    return out, report


def repair_pose3d(pose: Pose3D, *, config: RepairConfig) -> tuple[Pose3D, RepairReport]:
    """Hampel outliers and short gaps of `pose.joints (T, 17, 3)`; no swap repair (lifters keep
    the labels they were given). Confidence of filled joints as in 2D."""
    ts = pose.timestamps
    joints = pose.joints.astype(np.float64)
    outliers = take_outliers(joints, ts, skeleton=COCO17, config=config)
    conf0 = pose.confidence.astype(np.float64)
    out_joints, conf, gaps = refill(
        joints, conf0, outliers=outliers, timestamps=ts, max_gap_s=config.max_gap_s
    )
    before = np.concatenate([joints, conf0[..., None]], axis=-1)
    after = np.concatenate([out_joints, conf[..., None]], axis=-1)
    report = RepairReport(
        outliers=int(outliers.sum()),
        filled=int(gaps.sum()),
        swapped_frames=0,
        swap_runs=0,
        repaired=_changed(before, after),
    )
    out = replace(pose, joints=out_joints.astype(np.float32), confidence=conf.astype(np.float32))
    return out, report
