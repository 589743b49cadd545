"""The head's scores: a constant offset of HeadPitch or HeadYaw shows as their signed bias, a
turn across ±180° is a small error, and the direction error is the angle between the faces."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gesturebank.lift.scoring import head_bias_deg, score_angles
from gesturebank.robot.pepper import JOINTS

PITCH, YAW = JOINTS.index("HeadPitch"), JOINTS.index("HeadYaw")


def _angles(seed: int, count: int = 50) -> np.ndarray:
    rng = np.random.default_rng(seed)
    a = rng.uniform(-0.5, 0.5, (count, len(JOINTS)))
    a[:, YAW] = rng.uniform(-np.pi, np.pi, count)
    return a


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), pitch=st.floats(-30, 30), yaw=st.floats(-170, 170))
def test_a_constant_offset_is_the_bias(seed: int, pitch: float, yaw: float) -> None:
    truth = _angles(seed)
    mine = truth.copy()
    mine[:, PITCH] += np.deg2rad(pitch)
    mine[:, YAW] += np.deg2rad(yaw)  # may leave ±π: wrapped, still the same offset
    got_pitch, got_yaw = head_bias_deg(mine, truth)
    assert abs(got_pitch - pitch) < 1e-6 and abs(got_yaw - yaw) < 1e-6


def test_a_yaw_across_the_back_is_a_small_error() -> None:
    truth = np.zeros((2, len(JOINTS)))
    truth[:, YAW] = np.deg2rad(179.0)
    mine = truth.copy()
    mine[:, YAW] = np.deg2rad(-179.0)
    mine[1, PITCH] = np.nan  # unknown in one frame: left out of the pitch bias only
    assert np.allclose(head_bias_deg(mine, truth), (0.0, 2.0))
    per_joint, _, _, head = score_angles(mine, truth)
    assert abs(per_joint[YAW] - 2.0) < 1e-9
    assert abs(head - 2.0) < 1e-6  # the faces, level, are 2° apart
