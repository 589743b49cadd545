"""Snaps onto another person (issue 41): in a scene of several people a detector now and then
puts one of the speaker's joints on a joint of somebody else for a frame or three, at full
confidence (a wrist 1.4 shoulder widths away on the person behind, confidence 0.98), and comes
back. The Hampel filter misses a snap that lasts several frames of a short window, and the QC
only sees what repair left.

A keypoint's run of 1 to `repair.snap_max_frames` frames is a snap when, in each of its frames,
(a) it lies off the line between the frames before and after the run by more than
`repair.snap_min_jump` of the speaker's shoulder width, further than the run's two ends are
apart (it went out and came back), and (b) it lies within `repair.snap_near` shoulder widths of
a keypoint of another person in that frame. Whatever its confidence, it is set missing, so the
repair that follows interpolates it like any short gap (`repair.poses.repair_pose2d`).

Pure functions over arrays; `others_of` gathers the other people of a take's detections.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from gesturebank.config import RepairConfig
from gesturebank.poses import MultiPose2D, Pose2D
from gesturebank.repair.keypoints import shoulder_width
from gesturebank.skeletons import get_skeleton


def others_of(multi: MultiPose2D, ids: np.ndarray, *, track: np.ndarray) -> np.ndarray:
    """`(T, P, K, 2)` pixels of everybody detected in each frame but the person of `track (T,)`
    (their track id per frame, -1 nobody): the slots `ids (T, P)` gives another id, or none."""
    own = (np.asarray(ids) == np.asarray(track)[:, None]) & (np.asarray(track)[:, None] >= 0)
    xy = np.array(multi.keypoints[..., :2], dtype=np.float64, copy=True)
    xy[own] = np.nan
    return xy


def _nearest_other(xy: np.ndarray, others: np.ndarray) -> np.ndarray:
    """`(T, K)` distance from each keypoint of `xy (T, K, 2)` to the nearest keypoint of anybody
    in `others (T, P, K2, 2)` in the same frame (inf where there is nobody)."""
    t = len(xy)
    flat = others.reshape(t, -1, 2)
    d = np.linalg.norm(xy[:, :, None, :] - flat[:, None, :, :], axis=-1)
    return np.asarray(np.where(np.isnan(d), np.inf, d).min(axis=2, initial=np.inf))


def snap_frames(
    xy: np.ndarray, others: np.ndarray, *, scale: float, config: RepairConfig
) -> NDArray[np.bool_]:
    """`(T, K)` the keypoints of `xy (T, K, 2)` that snapped onto another person of `others
    (T, P, K2, 2)` (module docstring); `scale`: the person's shoulder width in pixels."""
    p = np.asarray(xy, dtype=np.float64)
    t, k = p.shape[:2]
    out = np.zeros((t, k), dtype=bool)
    if not (np.isfinite(scale) and scale > 0) or others.size == 0 or t < 3:
        return out
    near = _nearest_other(p, np.asarray(others, np.float64)) < config.snap_near * scale
    if not near.any():
        return out
    for n in range(1, config.snap_max_frames + 1):
        if t < n + 2:
            break
        before, after = p[: t - n - 1], p[n + 1 :]  # the frames either side of a run at a
        through = np.linalg.norm(after - before, axis=-1)  # (t − n − 1, K)
        hit = np.ones_like(through, dtype=bool)
        for i in range(n):
            line = before + (after - before) * (i + 1) / (n + 1)
            off = np.linalg.norm(p[1 + i : t - n + i] - line, axis=-1)
            with np.errstate(invalid="ignore"):
                hit &= (off > config.snap_min_jump * scale) & (off > through)
            hit &= near[1 + i : t - n + i]
        for a, j in zip(*np.nonzero(hit), strict=True):
            out[a + 1 : a + 1 + n, j] = True
    return out


def unsnap(
    pose: Pose2D, others: np.ndarray, *, config: RepairConfig
) -> tuple[Pose2D, NDArray[np.bool_]]:
    """`pose` with its snaps onto the people of `others` (`others_of`) set missing (NaN,
    confidence 0), and the `(T, K)` keypoints that were. `repair.snap_max_frames` 0: none."""
    xy = np.asarray(pose.keypoints[..., :2], dtype=np.float64)
    if config.snap_max_frames <= 0:
        return pose, np.zeros(xy.shape[:2], dtype=bool)
    scale = shoulder_width(points=xy, skeleton=get_skeleton(pose.skeleton))
    snapped = snap_frames(xy, others, scale=scale, config=config)
    if not snapped.any():
        return pose, snapped
    kp = np.array(pose.keypoints, copy=True)
    kp[snapped] = np.nan
    kp[snapped, 2] = 0.0
    world = None
    if pose.world is not None:
        world = np.array(pose.world, copy=True)
        world[snapped] = np.nan
    return replace(pose, keypoints=kp, world=world), snapped
