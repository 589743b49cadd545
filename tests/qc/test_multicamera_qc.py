"""A multi-camera clip is judged by its 3D as each of its cameras sees it, not by the stored 2D
(the reference camera's): facing away from every camera, sideways in every camera, the size in
the best camera, spikes / swaps / freezes of the triangulated joints."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from gesturebank.clip import Clip
from gesturebank.config import QCConfig
from gesturebank.geometry import Camera, CameraGroup
from gesturebank.qc import metrics as M
from gesturebank.qc.clip_metrics import ClipMetrics
from gesturebank.robot import pepper
from gesturebank.skeletons import COCO17
from tests.lift.test_triangulate import look_at

IDX = COCO17.index
# The synthetic speaker stands at the robot frame's origin facing +x, left +y, z up.
TARGET = np.array([0.0, 0.0, 0.2])


def camera(azimuth_deg: float, name: str, distance: float = 3.0) -> Camera:
    """A camera `distance` m away at `azimuth_deg` around the speaker (0: straight in front)."""
    a = np.radians(azimuth_deg)
    return look_at(distance * np.array([np.cos(a), np.sin(a), 0.0]) + TARGET, TARGET, name)


def rigged(clip: Clip, cameras: list[Camera]) -> Clip:
    """`clip` as a multi-camera take would store it: its cameras in the 3D pose."""
    return replace(clip, pose3d=replace(clip.pose3d, cameras=CameraGroup(cameras)))


def measure(clip: Clip) -> ClipMetrics:
    return M.clip_metrics(clip, profile=pepper.load_profile(), qc=QCConfig())


def test_the_cameras_survive_the_clip_file(clip) -> None:
    cams = [camera(20, "a"), camera(-40, "b")]
    back = Clip.from_arrays(rigged(clip, cams).to_arrays())
    got = M.take_cameras(back.pose3d)
    assert [c.name for c in got] == ["a", "b"]
    for c, g in zip(cams, got, strict=True):
        np.testing.assert_allclose(g.project(clip.pose3d.joints), c.project(clip.pose3d.joints))
    assert M.take_cameras(clip.pose3d) == []  # a single camera: the 2D rules


def test_facing_away_means_away_from_every_camera(clip) -> None:
    front = measure(rigged(clip, [camera(25, "a"), camera(-25, "b")]))
    assert front.facing_away_fraction == 0 and front.sideways_fraction == 0
    behind = [camera(160, "c"), camera(-160, "d")]
    assert measure(rigged(clip, behind)).facing_away_fraction == 1.0
    # one camera seeing the chest is enough: the hands in front of the body are triangulated
    assert measure(rigged(clip, [*behind, camera(40, "e")])).facing_away_fraction == 0


def test_sideways_means_from_the_side_in_every_camera(clip) -> None:
    sides = [camera(90, "l"), camera(-90, "r")]
    # (the head turns: in a few frames the nose comes back between the shoulders)
    assert measure(rigged(clip, sides)).sideways_fraction > 0.95
    assert measure(rigged(clip, [*sides, camera(180, "back")])).sideways_fraction == 0


def test_the_size_is_the_best_cameras(clip) -> None:
    near, far = camera(10, "near", distance=2.0), camera(-10, "far", distance=8.0)
    both = measure(rigged(clip, [far, near])).shoulder_width
    assert both == measure(rigged(clip, [near])).shoulder_width
    assert both > 3 * measure(rigged(clip, [far])).shoulder_width > 0


def test_a_2d_jump_of_the_reference_camera_is_not_judged_a_3d_one_is(clip) -> None:
    cams = [camera(25, "a"), camera(-25, "b")]
    kp = clip.pose2d.keypoints.copy()
    kp[40, IDX["left_wrist"], :2] += 300.0  # the stored 2D jumps out and back
    jumped = replace(clip, pose2d=replace(clip.pose2d, keypoints=kp))
    limit = QCConfig().max_spike
    assert measure(jumped).spike_max > limit  # one camera: its own 2D is what it has
    assert measure(rigged(jumped, cams)).spike_max < 0.1
    joints = clip.pose3d.joints.copy()
    joints[40, IDX["left_wrist"]] += [0.0, 0.6, 0.0]  # the triangulated wrist jumps
    spiked = rigged(replace(clip, pose3d=replace(clip.pose3d, joints=joints)), cams)
    assert measure(spiked).spike_max > limit


@pytest.mark.parametrize("azimuth", [0.0, 30.0, 160.0])
def test_one_camera_of_the_rig_agrees_with_the_2d_rule(clip, azimuth: float) -> None:
    """The rig's rule with one camera is the single camera's rule on that camera's image."""
    cam = camera(azimuth, "only")
    seen = np.where(clip.valid[..., None], clip.pose3d.joints, np.nan)
    xy = cam.project(seen)
    assert np.array_equal(
        M.facing_away_from_all([xy], clip.valid), M.facing_away(np.nan_to_num(xy), clip.valid)
    )
    assert np.array_equal(
        M.sideways_from_all([xy], clip.valid), M.sideways(np.nan_to_num(xy), clip.valid)
    )
