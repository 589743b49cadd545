"""The learned lifter's training pairs: the person stays in the picture of the camera that sees
them, so the network's inputs stay bounded (a camera the mocap's person walked up to gave inputs
of thousands of torso sizes, and the batch norms learned from them made the exported model lift
an average pose)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gesturebank.lift.learned import features as F
from gesturebank.lift.scoring import look_at
from gesturebank.mocap.bvh import read_bvh
from gesturebank.mocap.pose import motion_pose

pytest.importorskip("torch")
from gesturebank.lift.training.lifter_net import MIN_DEPTH_M, Sampler, in_picture

SIZE = (640, 480)


def _camera(distance: float):  # type: ignore[no-untyped-def]
    return look_at(eye=np.array([0.0, -distance, 1.3]), target=np.array([0.0, 0.0, 1.3]),
                   up=np.array([0.0, 0.0, 1.0]), size=SIZE, fov_deg=60.0)  # fmt: skip


@settings(max_examples=60, deadline=None)
@given(
    x=st.floats(-0.5, 0.5), z=st.floats(1.0, 1.6), distance=st.floats(2.0, 6.0),
    step=st.floats(-10.0, 10.0),
)  # fmt: skip
def test_a_point_is_in_the_picture_exactly_when_it_projects_inside_and_in_front(
    x: float, z: float, distance: float, step: float
) -> None:
    cam = _camera(distance)
    point = np.array([[[x, 0.0, z]]])
    local = cam.to_camera(point)
    px = cam.project(point)[0, 0]
    inside = bool(np.all(px > -0.1 * np.array(SIZE)) and np.all(px < 1.1 * np.array(SIZE)))
    assert in_picture(local, cam) == inside
    # walked towards the camera past it (or to within MIN_DEPTH_M): never in the picture
    near = point + np.array([0.0, -(distance - MIN_DEPTH_M / 2) + min(step, 0) * 0.01, 0.0])
    assert not in_picture(cam.to_camera(near), cam)


def test_training_inputs_stay_bounded(samples: Path) -> None:
    whole = motion_pose(read_bvh(samples / "bvhtools/testBvhFiles/test.bvh"))[0]
    grid = np.arange(51.0, whole.timestamps[-1], 1 / F.RATE_HZ)  # where the person walks about
    take = F.resample(whole.joints.astype(np.float64), whole.timestamps, grid)
    sampler = Sampler([take], frames=176)
    x, y = sampler.batch(np.random.default_rng(1), 96)
    # in torso sizes about the neck (and the neck's ray coordinates): a person in a 60° picture
    assert np.isfinite(x).all() and np.abs(x).max() < 5.0
    assert np.abs(y).max() < 3.0
