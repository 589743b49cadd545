"""`blazepose-world`: the learned lifter — BlazePose's own metric 3D world landmarks.

BlazePose GHUM predicts, with its 2D landmarks, 33 3D landmarks in metres with the origin between
the hips: x to the person's image-right, y down, z away from the camera (smaller = closer). That
frame is right-handed (x × y = z), so the landmarks only need re-ordering to COCO-17. Confidence
is the 2D visibility. Frames without a detection stay NaN.
"""

from __future__ import annotations

import numpy as np

from gesturebank.config import Config
from gesturebank.errors import InputError
from gesturebank.lift import LifterTraits, TakeViews
from gesturebank.lift.depth_confidence import BLAZEPOSE_WORLD
from gesturebank.poses import Pose3D
from gesturebank.skeletons import COCO17, get_skeleton


class BlazePoseWorldLifter:
    """Has no options: the detector made the 3D (its section is `detector`)."""

    name = "blazepose-world"
    traits = LifterTraits(depth_calibration=BLAZEPOSE_WORLD)

    @classmethod
    def from_config(cls, config: Config) -> BlazePoseWorldLifter:
        """The registry's factory (gesturebank.lift): no section of `config` is used."""
        return cls()

    def lift(self, views: TakeViews) -> Pose3D:
        """One view with `world` landmarks (from a BlazePose detector) → Pose3D (T, 17, 3), m."""
        pose2d = views.single(self.name)
        if pose2d.world is None:
            raise InputError(
                f"lifter {self.name!r} needs the 3D world landmarks of the mediapipe detector; "
                f"this pose comes from a {pose2d.skeleton!r} detector without them — use "
                "--lifter geometric or --detector mediapipe"
            )
        skeleton = get_skeleton(pose2d.skeleton)
        joints = skeleton.convert(pose2d.world, COCO17)
        confidence = skeleton.convert(pose2d.keypoints, COCO17)[..., 2]
        missing = np.isnan(joints).any(axis=-1) | np.isnan(confidence)
        joints[missing] = np.nan
        confidence = np.where(missing, np.nan, confidence)
        return Pose3D(
            joints,
            confidence,
            pose2d.timestamps,
            frame="blazepose-world",
            units="m",
            meta={"lifter": self.name},
        )
