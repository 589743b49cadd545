"""The learned lifter on real BlazePose output: metric, right-handed, facing the camera."""

from pathlib import Path

import numpy as np
import pytest

from gesturebank.app.extract import extract_take
from gesturebank.config import Config
from gesturebank.errors import InputError
from gesturebank.lift import LIFTERS, TakeViews
from gesturebank.poses import Pose2D
from gesturebank.skeletons import COCO17

J = COCO17.index


@pytest.fixture(scope="module")
def cam01_3d(samples: Path):
    video = samples / "pose2sim/Demo_SinglePerson/videos/cam01.mp4"
    pose2d = extract_take(video, Config()).tracked.pose
    return pose2d, LIFTERS.create("blazepose-world", Config()).lift(TakeViews.of(pose2d))


def test_metric_right_handed_and_plausible(cam01_3d) -> None:
    _, pose3d = cam01_3d
    assert pose3d.units == "m"
    j = pose3d.joints
    ok = np.isfinite(j[:, [J["left_shoulder"], J["right_shoulder"], J["nose"]]]).all(axis=(1, 2))
    assert ok.mean() > 0.95
    ls, rs = j[ok, J["left_shoulder"]], j[ok, J["right_shoulder"]]
    hips = (j[ok, J["left_hip"]] + j[ok, J["right_hip"]]) / 2
    width = np.linalg.norm(ls - rs, axis=1)
    assert 0.25 < np.median(width) < 0.5  # an adult's shoulders, in metres
    # BlazePose world frame: y down, so shoulders have smaller y than the hips
    assert np.all(((ls + rs) / 2)[:, 1] < hips[:, 1])
    # right-handed: (left − right shoulder) × up points out of the chest, toward the face
    up = (ls + rs) / 2 - hips
    forward = np.cross(ls - rs, up)
    nose = j[ok, J["nose"]] - (ls + rs) / 2
    assert np.mean(np.einsum("ij,ij->i", forward, nose) > 0) > 0.95


def test_confidence_is_the_visibility_and_missing_stays_nan(cam01_3d) -> None:
    pose2d, pose3d = cam01_3d
    coco = pose2d.to_coco17()
    np.testing.assert_array_equal(pose3d.confidence, coco.keypoints[..., 2])
    assert np.array_equal(np.isnan(pose3d.joints[..., 0]), np.isnan(coco.world[..., 0]))


def test_needs_world_landmarks() -> None:
    pose = Pose2D(np.zeros((2, 17, 3)), np.arange(2.0), "coco17", (10, 10))
    with pytest.raises(InputError, match="world landmarks"):
        LIFTERS.create("blazepose-world", Config()).lift(TakeViews.of(pose))
