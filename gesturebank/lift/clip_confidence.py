"""A clip's depth confidence per frame and its expected hand error, by its lifter's traits
(`lift.LifterTraits`, `lift.depth_confidence`)."""

from __future__ import annotations

import numpy as np

from gesturebank.errors import InputError
from gesturebank.lift import LIFTERS, LifterTraits
from gesturebank.lift.depth_confidence import hand_error_cm, pose_confidence
from gesturebank.mocap import MOCAP
from gesturebank.poses import Pose2D, Pose3D

MEASURED = LifterTraits(measured_depth=True)  # motion capture: no lifter, the 3D is read


def lifter_traits(name: str) -> LifterTraits:
    """The traits of lifter `name` (its factory's class attribute `traits`; motion capture's
    for MOCAP); the defaults for a lifter that declares none or is not installed (a dataset
    built with a plug-in read elsewhere)."""
    if name == MOCAP:
        return MEASURED
    try:
        factory = LIFTERS.get(name)
    except InputError:
        return LifterTraits()
    owner = getattr(factory, "__self__", factory)  # "Class.from_config": its class
    traits = getattr(owner, "traits", None)
    return traits if isinstance(traits, LifterTraits) else LifterTraits()


def lift_confidence(*, pose2d: Pose2D, pose3d: Pose3D, lifter: str) -> np.ndarray:
    """(T,) float32 depth confidence of a clip's lift (`lift.depth_confidence`): 1 where the 3D
    was measured (several cameras, motion capture), else from the view's 2D and the lift."""
    if lifter_traits(lifter).measured_depth:
        return np.ones(len(pose3d), np.float32)
    coco = pose2d.to_coco17().keypoints.astype(np.float64)
    return pose_confidence(xy=coco[..., :2], joints=pose3d.joints)


def expected_hand_error_cm(*, confidence: np.ndarray, lifter: str) -> float:
    """Mean Pepper hand error (cm) that frames of `confidence` (T,) lifted by `lifter` meant on
    the renders (its traits' `depth_calibration`); NaN for a lifter without one, or no frames."""
    return hand_error_cm(confidence=confidence, calibration=lifter_traits(lifter).depth_calibration)
