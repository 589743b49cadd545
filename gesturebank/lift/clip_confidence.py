"""A clip's depth confidence per frame, by its lifter (`lift.depth_confidence`)."""

from __future__ import annotations

import numpy as np

from gesturebank.lift.depth_confidence import pose_confidence
from gesturebank.mocap import MOCAP
from gesturebank.poses import Pose2D, Pose3D


def lift_confidence(*, pose2d: Pose2D, pose3d: Pose3D, lifter: str) -> np.ndarray:
    """(T,) float32 depth confidence of a clip's lift (`lift.depth_confidence`): 1 where the 3D
    was measured (several cameras, motion capture), else from the view's 2D and the lift."""
    if lifter in ("multiview", MOCAP):
        return np.ones(len(pose3d), np.float32)
    coco = pose2d.to_coco17().keypoints.astype(np.float64)
    return pose_confidence(xy=coco[..., :2], joints=pose3d.joints)
