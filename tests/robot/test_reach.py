"""robot.reach: continuous angles, held free angles, the soft reach map, the speed limit."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from gesturebank.config import RetargetConfig
from gesturebank.robot import pepper
from gesturebank.robot.reach import continuous, hold_free, reach_map, soft_limits, speed_limit

PROFILE = pepper.load_profile()
ANGLES = arrays(np.float64, (40, 11), elements=st.floats(-6.0, 6.0))


@settings(max_examples=50, deadline=None)
@given(angles=ANGLES, margin=st.floats(0.05, 1.0))
def test_soft_limits_are_inside_increasing_and_the_identity_away_from_the_limits(angles, margin):
    soft = soft_limits(angles, PROFILE.lower, upper=PROFILE.upper, margin=margin)
    assert np.all((soft > PROFILE.lower) | np.isclose(soft, PROFILE.lower, atol=1e-12))
    assert np.all((soft < PROFILE.upper) | np.isclose(soft, PROFILE.upper, atol=1e-12))
    m = np.minimum(margin, (PROFILE.upper - PROFILE.lower) / 4)
    inside = (angles >= PROFILE.lower + m) & (angles <= PROFILE.upper - m)
    np.testing.assert_array_equal(soft[inside], angles[inside])
    order = np.argsort(angles, axis=0)
    ranked = np.take_along_axis(soft, order, axis=0)
    assert np.all(np.diff(ranked, axis=0) >= 0)  # monotonic in the person's angle


def test_soft_reach_keeps_moving_where_clamp_holds_still() -> None:
    """An elbow bent on past ElbowRoll's limit and back: clamped, the robot stands at the limit;
    soft, it keeps following, slower, with the person's timing (velocity of the same sign)."""
    j = pepper.INDEX["RElbowRoll"]
    person = np.tile(pepper.neutral_pose(), (200, 1)).astype(np.float64)
    person[:, j] = PROFILE.upper[j] + 0.2 * np.sin(np.linspace(0, 2 * np.pi, 200))
    clamp = reach_map(person, profile=PROFILE, retarget=RetargetConfig(reach="clamp"))[:, j]
    soft = reach_map(person, profile=PROFILE, retarget=RetargetConfig(reach="soft"))[:, j]
    beyond = person[:, j] > PROFILE.upper[j]
    assert np.ptp(clamp[beyond]) < 1e-6
    step_p, step_s = np.diff(person[:, j]), np.diff(soft.astype(np.float64))
    moving = np.abs(step_p) > 1e-3
    assert np.all(np.sign(step_s[moving]) == np.sign(step_p[moving]))


@settings(max_examples=50, deadline=None)
@given(angles=ANGLES, step=st.floats(0.01, 0.5))
def test_speed_limit_bounds_every_step_and_keeps_slow_motion(angles, step):
    limited = speed_limit(angles, np.full(11, step))
    assert np.all(np.abs(np.diff(limited, axis=0)) <= step * (1 + 1e-9))
    slow = np.cumsum(np.full((40, 11), 0.9 * step), axis=0)
    np.testing.assert_array_equal(speed_limit(slow, np.full(11, step)), slow)


def test_continuous_keeps_the_branch_and_leaves_other_angles_bit_for_bit() -> None:
    path = np.angle(np.exp(1j * np.linspace(2.5, 4.0, 30)))  # crosses +π, wrapped
    rest = np.linspace(-1.0, 1.0, 30)
    got = continuous(np.stack([path, rest], axis=1))
    np.testing.assert_allclose(got[:, 0], np.linspace(2.5, 4.0, 30), atol=1e-12)
    np.testing.assert_array_equal(got[:, 1], rest)
    gap = path.copy()
    gap[10:20] = np.nan
    np.testing.assert_allclose(continuous(gap[:, None])[20:, 0], np.linspace(2.5, 4.0, 30)[20:])


def test_a_free_angle_is_held_and_turns_with_its_weight() -> None:
    x = np.array([1.0, 1.0, 2.5, -2.0, 1.0, 1.0])
    w = np.array([1.0, 0.5, 0.0, 0.0, 0.5, 1.0])
    np.testing.assert_allclose(hold_free(x, w), [1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    turned = hold_free(np.array([0.5, -2.5, -2.5, -2.5]), np.array([1.0, 0.0, 0.5, 1.0]))
    np.testing.assert_allclose(turned, [0.5, 0.5, -1.0, -2.5])  # through 0, not beyond ±π
