"""The head from the face (issue 40): a head whose axes are known (as the face mesh gives them)
turned Rz(yaw)·Ry(pitch)·Rx(roll) against the torso comes back as HeadPitch, HeadYaw and
head_roll, whatever the body's place, turn and size, and agrees with what `pepper_angles` and
`head_roll` read from the same head's face points."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from gesturebank.errors import InputError
from gesturebank.robot import pepper
from gesturebank.robot.retarget import head_from_axes, head_roll, pepper_angles
from tests.robot.test_head_roll import _joints

angle = st.floats(-1.3, 1.3)  # within ±75°: away from pitch ±90°, where roll and yaw merge


def _wrap(x: float) -> float:
    return (x + np.pi) % (2 * np.pi) - np.pi


@settings(max_examples=60, deadline=None)
@given(yaw=st.floats(-2.8, 2.8), pitch=angle, roll=angle, seed=st.integers(0, 2**31))
def test_a_known_head_rotation_comes_back(yaw: float, pitch: float, roll: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    turn = Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_matrix()  # torso frame: x fwd
    world = Rotation.random(random_state=rng).as_matrix()
    scale, shift = rng.uniform(0.01, 100.0), rng.normal(0, 10, 3)
    joints = scale * _joints(0.0, 0.0, 0.0)[None] @ world.T + shift
    axes = (world @ turn)[None]  # columns: the head's forward, left, up in the pose's axes
    got = head_from_axes(joints, axes)[0]
    assert got.dtype == np.float32
    assert got[0] == pytest.approx(pitch, abs=1e-4)
    assert _wrap(float(got[1]) - yaw) == pytest.approx(0.0, abs=1e-4)
    assert got[2] == pytest.approx(roll, abs=1e-4)


def test_agrees_with_the_face_points_of_the_same_head() -> None:
    turns = [(0.3, -0.2, 0.1), (-0.9, 0.4, -0.3), (1.2, 0.1, 0.0)]
    joints = np.stack([_joints(*t) for t in turns])
    axes = np.stack([Rotation.from_euler("ZYX", t).as_matrix() for t in turns])
    got = head_from_axes(joints, axes)
    a = pepper_angles(joints)
    np.testing.assert_allclose(got[:, 0], a[:, pepper.INDEX["HeadPitch"]], atol=1e-4)
    np.testing.assert_allclose(got[:, 1], a[:, pepper.INDEX["HeadYaw"]], atol=1e-4)
    np.testing.assert_allclose(got[:, 2], head_roll(joints), atol=1e-4)


def test_missing_axes_or_torso_are_nan_and_bad_shapes_refused() -> None:
    joints = np.stack([_joints(0.2, 0.1, 0.0)] * 3)
    axes = np.stack([np.eye(3)] * 3)
    axes[1] = np.nan
    joints[2, 5] = np.nan  # the left shoulder: no torso
    got = head_from_axes(joints, axes)
    assert np.isfinite(got[0]).all() and np.isnan(got[1:]).all()
    with pytest.raises(InputError, match="axes must be"):
        head_from_axes(joints, axes[:2])
