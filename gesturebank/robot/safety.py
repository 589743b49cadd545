"""Safety: what may reach a robot — limits, speed caps, smooth moves, live filter, timeline checks.

Every angle sent is clamped into the robot profile's limits and every joint's speed stays below
`max_speed_fraction` × its maximum velocity (`speed_profile`); `check_timeline` refuses a timeline
that looks wrong before anything moves. Pure functions over arrays, except `SafetyFilter`'s state.
"""

from __future__ import annotations

import dataclasses
import logging
import math

import numpy as np

from gesturebank.config import PlaybackConfig
from gesturebank.errors import InputError
from gesturebank.robot import pepper
from gesturebank.robot.timeline import Timeline

log = logging.getLogger(__name__)


def speed_profile(profile: pepper.RobotProfile, fraction: float) -> pepper.RobotProfile:
    """`profile` with every joint's velocity scaled by `fraction` (0, 1]."""
    return dataclasses.replace(profile, velocity=profile.velocity * fraction)


def safe_pose(pose: np.ndarray, profile: pepper.RobotProfile) -> np.ndarray:
    """One pose `(11,)` clamped into the limits, float32."""
    return pepper.clamp(np.asarray(pose, np.float32).reshape(1, -1), profile)[0]


def safe_angles(timeline: Timeline, profile: pepper.RobotProfile) -> np.ndarray:
    """Timeline angles clamped and speed-limited (velocities of `profile`): `(N, 11)` float32.

    Frame 0 is kept as clamped (the start move brings the robot there first).
    """
    clamped = pepper.clamp(timeline.angles, profile)
    if len(clamped) == 1:
        return clamped
    limited = pepper.limit_velocity(
        clamped, timestamps=timeline.times, profile=profile, start=clamped[0]
    )
    return pepper.clamp(limited, profile)


# An angle this close to a limit counts as inside: CSV rounding and raw retargeted angles (a
# straight elbow at 0 rad, limit ∓0.0087) put sound timelines a hair outside.
_LIMIT_SLACK_RAD = 0.05


def check_timeline(
    timeline: Timeline,
    *,
    name: str,
    profile: pepper.RobotProfile,
    config: PlaybackConfig,
    clamp: bool = False,
) -> None:
    """Refuse (InputError, one line naming `name`) a timeline that does not look like one to
    play: its first frame before 0 or after `config.max_start_s`, a gap between frames longer
    than `config.max_gap_s`, or — unless `clamp` — angles far outside `profile`: any beyond ±2π,
    or more than `config.max_outside_share` of the frames beyond the limits. Angles that are
    beyond the limits but let through are logged as a warning (the player clamps them)."""
    t, a = timeline.times, timeline.angles
    if not 0 <= t[0] <= config.max_start_s:
        raise InputError(
            f"{name}: first frame at t = {t[0]:.3f} s; a timeline starts between 0 (the audio's "
            f"start) and playback.max_start_s = {config.max_start_s:g} s"
        )
    gaps = np.diff(t)
    if len(gaps) and float(gaps.max()) > config.max_gap_s:
        k = int(np.argmax(gaps))
        raise InputError(
            f"{name}: no frames for {gaps[k]:.3f} s after t = {t[k]:.3f} s "
            f"(more than playback.max_gap_s = {config.max_gap_s:g} s)"
        )
    beyond = (a < profile.lower - _LIMIT_SLACK_RAD) | (a > profile.upper + _LIMIT_SLACK_RAD)
    if not np.any(beyond):
        return
    wild = np.abs(a) > 2 * np.pi
    i, j = np.argwhere(wild if np.any(wild) else beyond)[0]
    example = f"{pepper.JOINTS[j]} = {a[i, j]:.4g} rad at t = {t[i]:.2f} s"
    share = float(np.mean(np.any(beyond, axis=1)))
    limits = f"the {profile.name} limits"
    if not clamp and (np.any(wild) or share > config.max_outside_share):
        what = (
            f"{example} is beyond ±2π"
            if np.any(wild)
            else f"{share:.0%} of the frames are beyond {limits} (e.g. {example})"
        )
        raise InputError(
            f"{name}: {what}: looks like degrees? Angles must be radians; --clamp plays it "
            f"clamped into {limits}"
        )
    log.warning(
        "%s: %.1f%% of the frames beyond %s, clamped (%s)", name, 100 * share, limits, example
    )


def ramp(
    start: np.ndarray,
    end: np.ndarray,
    *,
    profile: pepper.RobotProfile,
    min_duration: float,
    rate_hz: float,
) -> tuple[np.ndarray, np.ndarray]:
    """A minimum-jerk move `start (11,)` → `end (11,)`: `(times (M,), angles (M, 11))`.

    times are seconds after the move starts, (0, D]; the last row is `end`. D is at least
    `min_duration` and long enough for every joint's speed to stay within `profile`: a
    minimum-jerk move peaks at 1.875 × its mean speed, plus a 5 % margin for sampling.
    """
    a = np.asarray(start, np.float64)
    b = np.asarray(end, np.float64)
    need = 1.875 * float(np.max(np.abs(b - a) / profile.velocity)) * 1.05
    duration = max(min_duration, need, 1.0 / rate_hz)
    n = max(1, math.ceil(duration * rate_hz))
    tau = np.arange(1, n + 1) / n
    s = tau**3 * (10 - 15 * tau + 6 * tau**2)  # minimum-jerk position profile
    times = tau * duration
    angles = a + s[:, None] * (b - a)
    # Safety net: the sampled move must also pass the same speed limit as everything else.
    angles = pepper.limit_velocity(angles, timestamps=times, profile=profile, start=a)
    return times, pepper.clamp(angles, profile)


class SafetyFilter:
    """Per-frame safety for live mode: clamp, then limit the step from the last pose sent."""

    def __init__(self, profile: pepper.RobotProfile, start: np.ndarray) -> None:
        self.profile = profile
        self.last = safe_pose(start, profile)

    def step(self, angles: np.ndarray, dt: float) -> np.ndarray:
        """`angles (11,)` rad → the pose to send `(11,)` float32, `dt` s after the last one."""
        target = safe_pose(angles, self.profile)
        target = np.where(np.isnan(target), self.last, target)  # a missing value holds still
        step = self.profile.velocity * max(dt, 0.0)
        self.last = np.clip(target, self.last - step, self.last + step).astype(np.float32)
        return self.last
