"""The player's safety and schedule, on the `record` backend (virtual clock, no waiting)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturebank.errors import RobotError
from gesturebank.robot import pepper
from gesturebank.robot.backends import Command
from gesturebank.robot.backends.record import RecordBackend, read_record
from gesturebank.robot.playback import (
    PlaybackConfig,
    SafetyFilter,
    adaptive_sleep,
    play,
    ramp,
    replay_command,
)
from gesturebank.robot.timeline import Timeline, write_csv

PROFILE = pepper.load_profile("pepper-1.7")
# Table 3.1 of the dissertation, typed in independently of the profile file (rad).
LOWER = np.array([-0.7068, -2.0857, 0.0087, -2.0857, -1.5620, -2.0857, -1.5620, -2.0857, 0.0087,
                  -2.0857, -0.5149])  # fmt: skip
UPPER = np.array([0.4451, 2.0857, 1.5620, 2.0857, -0.0087, 2.0857, -0.0087, 2.0857, 1.5620,
                  2.0857, 0.5149])  # fmt: skip
VELOCITY = PROFILE.velocity
ARMS_UP = np.array([0.3, 0.8, 1.2, -1.0, -1.0, 0.5, -1.2, -1.0, 1.0, -0.5, 0.2])
NEUTRAL = np.clip(np.array([0, 0, 0, np.pi / 2, 0, 0, 0, np.pi / 2, 0, 0, 0]), LOWER, UPPER)
FAST = PlaybackConfig(start_s=0.3, return_s=0.3)


def wild_timeline(n: int = 120) -> Timeline:
    """Asks for angles beyond every limit and for a jump no motor can make."""
    t = np.arange(n) * 0.01
    a = np.tile(NEUTRAL, (n, 1))
    a[:, 0] = 1.0  # HeadPitch above its 0.4451 limit
    a[:, 2] = -0.5  # LShoulderRoll below its lower limit
    a[n // 2 :, 3] = -3.0  # LShoulderPitch: beyond the limit, and a jump
    a[:, 10] = 0.3 * np.sin(2 * np.pi * t)
    return Timeline.of(t, a)


def check_safe(angles: np.ndarray, dt: float) -> None:
    assert np.all(angles >= LOWER - 1e-6) and np.all(angles <= UPPER + 1e-6)
    speed = np.abs(np.diff(angles, axis=0)) / dt
    assert np.all(speed <= VELOCITY * (1 + 1e-4) + 1e-4)


def test_adaptive_sleep_is_eq_4_1() -> None:
    assert adaptive_sleep(due=1.0, now=0.99, eta=0.95) == pytest.approx(0.0095)
    assert adaptive_sleep(due=1.0, now=1.002, eta=0.95) == 0.0
    assert adaptive_sleep(due=2.0, now=1.0, eta=1.0) == pytest.approx(1.0)


def test_ramp_is_smooth_and_within_speed() -> None:
    times, angles = ramp(ARMS_UP, NEUTRAL, profile=PROFILE, min_duration=0.2, rate_hz=100)
    np.testing.assert_allclose(angles[-1], NEUTRAL, atol=1e-6)
    assert times[-1] >= 0.2
    check_safe(np.vstack([ARMS_UP, angles]), dt=float(times[0]))
    # HipRoll is the slowest joint (2.27 rad/s): 0.2 rad cannot be moved in less than 0.088 s.
    assert np.all(np.diff(times) > 0)


def test_play_record_is_safe_smooth_and_on_schedule(tmp_path: Path) -> None:
    tl = wild_timeline()
    be = RecordBackend(tmp_path / "r.jsonl", start_pose=ARMS_UP)
    result = play(tl, be, config=FAST)
    be.close()
    calls = read_record(tmp_path / "r.jsonl")
    assert result.status == "completed" and result.mode == "stream"
    assert {c["call"] for c in calls} == {"setAngles"}
    assert all(c["names"] == list(pepper.JOINTS) for c in calls)
    phases = [c["phase"] for c in calls]
    assert phases == sorted(phases, key=["start", "timeline", "return"].index)
    angles = np.array([c["angles"] for c in calls])
    check_safe(np.vstack([ARMS_UP, angles]), dt=0.01)
    # Smooth start from the robot's pose, a timeline on its own clock, a smooth end at neutral.
    assert np.max(np.abs(angles[0] - ARMS_UP)) < 0.1
    timeline = [c for c in calls if c["phase"] == "timeline"]
    np.testing.assert_allclose([c["t"] for c in timeline], tl.times, atol=1e-6)
    np.testing.assert_allclose(angles[-1], NEUTRAL, atol=1e-5)
    assert np.max(np.abs(angles[-2] - NEUTRAL)) < 1e-3  # arrived gently, not in a jump
    # What could be followed was followed exactly: HipRoll's sine is within every limit.
    np.testing.assert_allclose([c["angles"][10] for c in timeline], tl.angles[:, 10], atol=1e-5)


def test_interpolate_mode_sends_whole_timeline_in_one_call(tmp_path: Path) -> None:
    tl = wild_timeline()
    be = RecordBackend(tmp_path / "r.jsonl", start_pose=ARMS_UP)
    result = play(tl, be, config=FAST.model_copy(update={"mode": "interpolate"}))
    be.close()
    calls = read_record(tmp_path / "r.jsonl")
    assert result.mode == "interpolate"
    assert [c["phase"] for c in calls] == ["start", "timeline", "return"]
    for c in calls:
        times = np.array(c["timeLists"][0])
        assert times[0] > 0 and np.all(np.diff(times) > 0)
        keys = np.array(c["angleLists"]).T
        assert keys.shape == (len(times), 11)
        check_safe(keys, dt=float(np.min(np.diff(times))))


class InterruptingBackend(RecordBackend):
    """A record backend whose user presses Ctrl-C (or whose robot fails) at timeline frame k."""

    def __init__(self, path: Path, k: int, exc: BaseException) -> None:
        super().__init__(path, start_pose=ARMS_UP)
        self.k, self.exc, self.n = k, exc, 0

    def send(self, cmd: Command) -> None:
        if cmd.phase == "timeline":
            self.n += 1
            if self.n == self.k:
                raise self.exc
        super().send(cmd)


def test_ctrl_c_returns_smoothly_to_neutral(tmp_path: Path) -> None:
    be = InterruptingBackend(tmp_path / "r.jsonl", 40, KeyboardInterrupt())
    result = play(wild_timeline(), be, config=FAST)
    be.close()
    calls = read_record(tmp_path / "r.jsonl")
    assert result.status == "interrupted"
    assert sum(c["phase"] == "timeline" for c in calls) == 39
    ret = np.array([c["angles"] for c in calls if c["phase"] == "return"])
    assert len(ret) >= 30  # at least return_s at 100 Hz, not a jump
    check_safe(np.array([c["angles"] for c in calls]), dt=0.01)
    np.testing.assert_allclose(ret[-1], NEUTRAL, atol=1e-5)


def test_error_returns_to_neutral_then_raises(tmp_path: Path) -> None:
    be = InterruptingBackend(tmp_path / "r.jsonl", 10, RobotError("robot said no"))
    with pytest.raises(RobotError, match="robot said no"):
        play(wild_timeline(), be, config=FAST)
    be.close()
    calls = read_record(tmp_path / "r.jsonl")
    assert calls[-1]["phase"] == "return"
    np.testing.assert_allclose(calls[-1]["angles"], NEUTRAL, atol=1e-5)


def test_safety_filter_clamps_and_limits_speed() -> None:
    f = SafetyFilter(PROFILE, NEUTRAL)
    out = f.step(np.full(11, 5.0), dt=0.01)
    assert np.all(out <= UPPER + 1e-6)
    np.testing.assert_array_less(np.abs(out - NEUTRAL), VELOCITY * 0.01 + 1e-6)
    held = f.step(np.full(11, np.nan), dt=0.01)  # a missing value holds still
    np.testing.assert_array_equal(held, out)


def test_replay_command_record(tmp_path: Path) -> None:
    csv = write_csv(tmp_path / "a.csv", wild_timeline(30))
    result = replay_command(csv, "record", out=tmp_path / "r.jsonl", config=FAST)
    assert not isinstance(result, Path) and result.n_frames == 30
    assert sum(c["phase"] == "timeline" for c in read_record(tmp_path / "r.jsonl")) == 30


OPTION_ERRORS = [("record", "--out"), ("sim", "--out"), ("naoqi", "--url"), ("nao", "unknown")]


@pytest.mark.parametrize(("backend", "needle"), OPTION_ERRORS)
def test_replay_command_options(tmp_path: Path, backend: str, needle: str) -> None:
    csv = write_csv(tmp_path / "a.csv", wild_timeline(5))
    with pytest.raises(Exception, match=needle):
        replay_command(csv, backend)
