"""datasets.process: raw angles at the video's times → clamped, low-passed 100 Hz angles."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gesturebank.config import ProcessingConfig, RetargetConfig
from gesturebank.datasets.process import process_angles
from gesturebank.filters import butter_lowpass, clock, interpolate_at
from gesturebank.robot import pepper

PROFILE = pepper.load_profile()
YAW = pepper.INDEX["HeadYaw"]


def _run(raw: np.ndarray, t: np.ndarray, reach: str = "clamp") -> np.ndarray:
    return process_angles(
        raw=raw,
        timestamps=t,
        clock=clock(float(t[0]), float(t[-1]), rate_hz=100.0),
        processing=ProcessingConfig(),
        retarget=RetargetConfig(reach=reach),
        profile=PROFILE,
    ).angles


def test_a_head_turned_away_stays_at_its_limit_not_swept_through_zero() -> None:
    """HeadYaw swinging across ±π (178° ↔ −178°, a head turned away from the camera): wrapped,
    the raw angle steps by 356°, and interpolated and filtered as it is that step became a sweep
    through 0 — across the joint's whole range. Unwrapped, every processed value stays far from
    0: at the limit of the side the head is on."""
    t = np.arange(90) / 30.0
    raw = np.tile(pepper.neutral_pose(), (len(t), 1))
    raw[:, YAW] = np.angle(np.exp(1j * (np.pi + np.radians(2.0) * np.sin(2 * np.pi * t))))
    yaw = _run(raw, t)[:, YAW]
    assert np.all(np.abs(yaw) >= PROFILE.upper[YAW] - 1e-6)  # ±119.5°: never in between


def test_angles_inside_the_range_are_processed_bit_for_bit_as_before() -> None:
    """No step across ±π: unwrapping and wrapping back change nothing, not even the last bit."""
    rng = np.random.default_rng(0)
    t = np.sort(rng.uniform(0, 3, 90))
    t[0], t[-1] = 0.0, 3.0
    raw = pepper.neutral_pose() + 0.3 * np.sin(2 * np.pi * 0.7 * t[:, None] + np.arange(11))
    p = ProcessingConfig()
    times = clock(0.0, 3.0, rate_hz=100.0)
    angles, _ = interpolate_at(raw, t, query=times, max_gap_s=p.max_gap_s)
    plain = pepper.clamp(
        butter_lowpass(angles, p.rate_hz, cutoff_hz=p.cutoff_hz, order=p.butter_order).astype(
            np.float32
        ),
        PROFILE,
    )
    np.testing.assert_array_equal(_run(raw, t), plain)


@settings(max_examples=60, deadline=None)
@given(
    joint=st.sampled_from(["HeadYaw", "LShoulderPitch", "RShoulderPitch"]),
    side=st.sampled_from([-1.0, 1.0]),
    before=st.floats(0.05, 1.0),
    after=st.floats(0.05, 1.0),
    at=st.integers(5, 55),
    reach=st.sampled_from(["clamp", "soft"]),
)
def test_a_crossing_of_pi_stays_on_the_side_it_left_from(joint, side, before, after, at, reach):
    """A head turning on round to its back, an arm raised overhead and on behind: the raw angle
    leaves the range at one limit and crosses ±π between two frames (atan2 wraps it to the far
    side). The processed angle stays beyond the limit it left from: never on the other side."""
    j = pepper.INDEX[joint]
    t = np.arange(60) / 30.0
    raw = np.tile(pepper.neutral_pose(), (len(t), 1))
    # inside the range near the limit, out past it, across ±π at frame `at`, on beyond
    path = np.concatenate(
        [
            np.linspace(PROFILE.upper[j] - 0.3, np.pi - before * 0.5, at),
            np.linspace(np.pi + after * 0.2, np.pi + after * 0.4, len(t) - at),
        ]
    )
    raw[:, j] = side * np.angle(np.exp(1j * path))  # wrapped, as atan2 gives it
    got = _run(raw, t, reach)[:, j]
    assert np.all(side * got > 0), got
    assert side * got[-1] > PROFILE.upper[j] - 0.15  # at (clamp) or near (soft) its limit


def test_an_angle_that_goes_on_round_is_taken_on_its_nearer_side_at_the_robots_speed() -> None:
    """A forearm turned on past ±π until it is much nearer the other limit (here 230° = −130°,
    0.18 rad past −119.5° but 1.97 rad past +119.5°): the processed angle goes there, as a
    sweep no faster than the joint's speed, instead of staying frozen at the far limit."""
    j = pepper.INDEX["LElbowYaw"]
    t = np.arange(90) / 30.0
    raw = np.tile(pepper.neutral_pose(), (len(t), 1))
    path = np.concatenate([np.linspace(1.5, np.radians(230), 30), np.full(60, np.radians(230))])
    raw[:, j] = np.angle(np.exp(1j * path))
    got = _run(raw, t)[:, j].astype(np.float64)
    assert got[-1] == pytest.approx(PROFILE.lower[j], abs=1e-3)
    assert np.abs(np.diff(got)).max() <= PROFILE.velocity[j] / 100 * (1 + 1e-5)
