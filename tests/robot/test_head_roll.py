"""Head roll (issue 32: seeds 002/004 use three head angles; Pepper plays two): a head turned
Rz(yaw)·Ry(pitch)·Rx(roll) in the torso frame gives back its roll, whatever the body's place,
turn and size; yaw and pitch come back as `pepper_angles` measures them."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from gesturebank.robot import pepper
from gesturebank.robot.retarget import head_roll, pepper_angles
from gesturebank.skeletons import COCO17

# A person in the torso frame (forward, left, up), metres; the head's points about its centre,
# face along x̂ (eyes and ears level: pitch 0), left along ŷ.
BODY = {
    "left_shoulder": (0.0, 0.19, 1.45),
    "right_shoulder": (0.0, -0.19, 1.45),
    "left_elbow": (0.0, 0.19, 1.16),
    "right_elbow": (0.0, -0.19, 1.16),
    "left_wrist": (0.0, 0.19, 0.90),
    "right_wrist": (0.0, -0.19, 0.90),
    "left_hip": (0.0, 0.11, 0.95),
    "right_hip": (0.0, -0.11, 0.95),
    "left_knee": (0.0, 0.11, 0.5),
    "right_knee": (0.0, -0.11, 0.5),
    "left_ankle": (0.0, 0.11, 0.08),
    "right_ankle": (0.0, -0.11, 0.08),
}
HEAD_CENTRE = np.array([0.0, 0.0, 1.64])
HEAD = {
    "nose": (0.11, 0.0, -0.04),
    "left_eye": (0.08, 0.032, 0.0),
    "right_eye": (0.08, -0.032, 0.0),
    "left_ear": (0.0, 0.075, 0.0),
    "right_ear": (0.0, -0.075, 0.0),
}


def _joints(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """(17, 3) COCO-17 joints with the head turned Rz(yaw)·Ry(pitch)·Rx(roll)."""
    turn = Rotation.from_euler("ZYX", [yaw, pitch, roll])  # intrinsic: Rz·Ry·Rx
    points = {k: np.array(v) for k, v in BODY.items()}
    points |= {k: HEAD_CENTRE + turn.apply(v) for k, v in HEAD.items()}
    return np.stack([points[name] for name in COCO17.joints])


def _similarity(rng: np.random.Generator, joints: np.ndarray) -> np.ndarray:
    """A random rotation (det +1), shift and uniform scale of (T, 17, 3)."""
    rot = Rotation.random(random_state=rng).as_matrix()
    return rng.uniform(0.01, 100.0) * joints @ rot.T + rng.normal(0, 10, 3)


def _wrap(x: np.ndarray) -> np.ndarray:
    return (x + np.pi) % (2 * np.pi) - np.pi


angle = st.floats(-1.3, 1.3)  # within ±75°: away from pitch ±90°, where roll and yaw merge


@settings(max_examples=60, deadline=None)
@given(yaw=st.floats(-2.8, 2.8), pitch=angle, roll=angle, seed=st.integers(0, 2**31))
def test_roll_comes_back_anywhere(yaw: float, pitch: float, roll: float, seed: int) -> None:
    joints = _similarity(np.random.default_rng(seed), _joints(yaw, pitch, roll)[None])
    assert head_roll(joints)[0] == pytest.approx(roll, abs=1e-4)
    a = pepper_angles(joints)[0]
    assert _wrap(a[pepper.INDEX["HeadYaw"]] - yaw) == pytest.approx(0.0, abs=1e-4)
    assert a[pepper.INDEX["HeadPitch"]] == pytest.approx(pitch, abs=1e-4)


def test_left_ear_up_is_positive_and_level_is_zero() -> None:
    tilted = _joints(0.0, 0.0, np.deg2rad(20))
    left, right = COCO17.index["left_ear"], COCO17.index["right_ear"]
    assert tilted[left, 2] > tilted[right, 2]
    rolls = head_roll(np.stack([tilted, _joints(0.4, 0.2, 0.0)]))
    assert rolls.dtype == np.float32
    assert rolls[0] == pytest.approx(np.deg2rad(20), abs=1e-5)
    assert rolls[1] == pytest.approx(0.0, abs=1e-5)


def test_unseen_face_is_nan() -> None:
    joints = _joints(0.1, 0.1, 0.1)[None].copy()
    for name in ("left_eye", "right_eye", "left_ear", "right_ear"):
        joints[0, COCO17.index[name]] = np.nan
    assert np.isnan(head_roll(joints)).all()
