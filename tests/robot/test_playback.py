"""The player's safety and schedule, on the `record` backend (virtual clock, no waiting)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gesturebank.cli.robot import replay_command
from gesturebank.config import PlaybackConfig
from gesturebank.errors import InputError, RobotError
from gesturebank.robot import pepper
from gesturebank.robot.backends import Command
from gesturebank.robot.backends.record import RecordBackend, read_record
from gesturebank.robot.clock import adaptive_sleep
from gesturebank.robot.playback import play
from gesturebank.robot.safety import SafetyFilter, ramp
from gesturebank.robot.timeline import Timeline, write_timeline

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
BIN = Path(sys.executable).parent


def wild_timeline(n: int = 120) -> Timeline:
    """Asks for angles beyond every limit and for a jump no motor can make."""
    t = np.arange(n) * 0.01
    a = np.tile(NEUTRAL, (n, 1))
    a[:, 0] = 1.0  # HeadPitch above its 0.4451 limit
    a[:, 2] = -0.5  # LShoulderRoll below its lower limit
    a[n // 2 :, 3] = -3.0  # LShoulderPitch: beyond the limit, and a jump
    a[:, 10] = 0.15 * np.sin(2 * np.pi * t)  # 0.94 rad/s at most: half HipRoll's 2.27 is more
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
    # What could be followed was followed exactly: HipRoll's sine is within every limit (and
    # within the default speed cap).
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
    csv = write_timeline(tmp_path / "a.csv", wild_timeline(30))
    result = replay_command(
        csv, backend="record", out=tmp_path / "r.jsonl", config=FAST, clamp=True
    )
    assert not isinstance(result, Path) and result.n_frames == 30
    assert sum(c["phase"] == "timeline" for c in read_record(tmp_path / "r.jsonl")) == 30


OPTION_ERRORS = [("record", "--out"), ("sim", "--out"), ("naoqi", "--url"), ("nao", "unknown")]


@pytest.mark.parametrize(("backend", "needle"), OPTION_ERRORS)
def test_replay_command_options(tmp_path: Path, backend: str, needle: str) -> None:
    csv = write_timeline(tmp_path / "a.csv", wild_timeline(5))
    with pytest.raises(Exception, match=needle):
        replay_command(csv, backend=backend, clamp=True)


# --------------------------------------------------------------------------------------------------
# Replay refuses timelines that look wrong (issue #16, item 4)


def gesture(n: int = 200, rate_hz: float = 100.0) -> Timeline:
    """A plausible timeline in radians, within every limit: neutral, the head turning a little."""
    t = np.arange(n) / rate_hz
    a = np.tile(NEUTRAL, (n, 1))
    a[:, 1] = 0.3 * np.sin(2 * np.pi * t)
    return Timeline.of(t, a)


def refused(path: Path, out: Path) -> str:
    with pytest.raises(InputError) as info:
        replay_command(path, backend="record", out=out, config=FAST)
    msg = str(info.value)
    assert str(path) in msg and "\n" not in msg
    assert not out.exists()  # refused before anything was written
    return msg


@pytest.mark.parametrize("scale", [180 / np.pi, 1e9])
def test_replay_refuses_degrees_unless_clamp(tmp_path: Path, scale: float) -> None:
    tl = gesture()
    csv = write_timeline(tmp_path / "deg.csv", Timeline.of(tl.times, tl.angles * scale))
    out = tmp_path / "r.jsonl"
    assert "looks like degrees?" in refused(csv, out)
    result = replay_command(csv, backend="record", out=out, config=FAST, clamp=True)
    assert not isinstance(result, Path) and result.status == "completed"
    check_safe(np.array([c["angles"] for c in read_record(out)]), dt=0.01)


def test_replay_refuses_many_frames_beyond_the_limits(tmp_path: Path, caplog) -> None:
    # Within ±2π, but HeadPitch 1.0 rad (limit 0.4451) in 20 % of the frames: refused;
    # in 2 % of them (below max_outside_share 5 %): played clamped, with a warning.
    out = tmp_path / "r.jsonl"
    for share, ok in ((0.2, False), (0.02, True)):
        tl = gesture()
        angles = tl.angles.copy()
        angles[: int(share * len(tl)), 0] = 1.0
        csv = write_timeline(tmp_path / f"head{share}.csv", Timeline.of(tl.times, angles))
        if not ok:
            msg = refused(csv, out)
            assert "20% of the frames" in msg and "HeadPitch = 1 rad" in msg
            continue
        with caplog.at_level("WARNING", logger="gesturebank.robot.safety"):
            replay_command(csv, backend="record", out=out, config=FAST)
        assert "2.0% of the frames beyond" in caplog.text
    # A sound timeline passes without a word.
    caplog.clear()
    replay_command(
        write_timeline(tmp_path / "ok.csv", gesture()), backend="record", out=out, config=FAST
    )
    assert "beyond" not in caplog.text


def test_replay_refuses_gaps_and_far_starts(tmp_path: Path) -> None:
    tl = gesture()
    out = tmp_path / "r.jsonl"
    gap = tl.times.copy()
    gap[100:] += 5.0  # 5 s without a frame, then a jump
    gap_csv = write_timeline(tmp_path / "gap.csv", Timeline.of(gap, tl.angles))
    assert "playback.max_gap_s" in refused(gap_csv, out)
    late_csv = write_timeline(tmp_path / "late.csv", Timeline.of(tl.times + 1000, tl.angles))
    assert "playback.max_start_s" in refused(late_csv, out)
    early_csv = write_timeline(tmp_path / "early.csv", Timeline.of(tl.times - 1, tl.angles))
    assert "playback.max_start_s" in refused(early_csv, out)
    # The bounds are the config's: raised, the same files play.
    loose = FAST.model_copy(update={"max_gap_s": 6.0, "max_start_s": 2000.0})
    for csv in (gap_csv, late_csv):
        result = replay_command(csv, backend="record", out=out, config=loose)
        assert not isinstance(result, Path) and result.status == "completed"


def test_speed_is_capped_at_max_speed_fraction(tmp_path: Path) -> None:
    # LShoulderPitch asked to jump by 3 rad: it moves at the cap, 0.5 of its velocity by default.
    n = 100
    a = np.tile(NEUTRAL, (n, 1))
    a[n // 2 :, 3] = -1.4
    tl = Timeline.of(np.arange(n) * 0.01, a)
    for fraction in (None, 1.0):
        cfg = FAST if fraction is None else FAST.model_copy(update={"max_speed_fraction": fraction})
        be = RecordBackend(tmp_path / "r.jsonl", start_pose=NEUTRAL)
        play(tl, be, config=cfg)
        be.close()
        calls = [c for c in read_record(tmp_path / "r.jsonl") if c["phase"] == "timeline"]
        cap = PlaybackConfig().max_speed_fraction if fraction is None else fraction
        assert {c["fractionMaxSpeed"] for c in calls} == {cap}
        speed = np.max(np.abs(np.diff([c["angles"][3] for c in calls])) / 0.01)
        assert speed == pytest.approx(cap * VELOCITY[3], rel=1e-3)
    assert PlaybackConfig().max_speed_fraction < 1.0  # conservative: the dissertation used 1.0


def test_old_speed_fraction_key_still_loads(tmp_path: Path) -> None:
    # Datasets (dataset.json) and config files written before the rename keep loading.
    from gesturebank.config import load_config

    old = tmp_path / "old.toml"
    old.write_text("[playback]\nspeed_fraction = 0.3\n")
    assert load_config(old).playback.max_speed_fraction == 0.3
    newer = load_config(old, [{"playback": {"max_speed_fraction": 0.8}}])
    assert newer.playback.max_speed_fraction == 0.8  # the new key, when given too, wins
    assert "speed_fraction" not in newer.to_json_dict()["playback"]


def test_cli_replay_degrees_exit_2_and_clamp(tmp_path: Path) -> None:
    tl = gesture()
    csv = write_timeline(tmp_path / "deg.csv", Timeline.of(tl.times, np.degrees(tl.angles)))
    cmd = [str(BIN / "gesturebank"), "replay", str(csv), "--backend", "record"]
    cmd += ["--out", str(tmp_path / "r.jsonl"), "--set", "playback.start_s=0.3"]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "looks like degrees?" in lines[0] and str(csv) in lines[0]
    r = subprocess.run([*cmd, "--clamp"], capture_output=True, text=True, timeout=120, check=False)
    assert r.returncode == 0, r.stderr
    assert "replay completed" in r.stdout
