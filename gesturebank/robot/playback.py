"""The timeline player: plays an angle timeline on a backend, safely, in sync with its audio.

Safety, on every backend (the backends only translate):
- every angle sent is clamped into the robot profile's limits;
- every joint's speed stays below `max_speed_fraction` × its maximum velocity;
- playback starts by moving smoothly from the robot's current pose (read from it) to frame 0,
  and ends — normally, on Ctrl-C, or on an error — by moving smoothly back to the neutral pose;
- a lost connection stops playback with one line (RobotError) instead of a traceback.
`replay` also refuses a timeline that looks wrong (`check_timeline`): angles far outside the
limits (degrees?) unless told to clamp, a gap in its times, a first frame long after the audio.

Timing: frame i of the timeline is due at t0 + times[i], where t0 is the moment the audio starts.
Two modes (`PlaybackConfig.mode`):
- `stream`: one setAngles per frame, each preceded by the adaptive sleep of Eq. 4.1;
- `interpolate`: one time-stamped call for the whole timeline (ALMotion angleInterpolation),
  where the backend supports it.
The default is the mode that kept better sync in `benchmarks/playback.py` (see its docstring).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np

from gesturebank.config import PlaybackConfig
from gesturebank.errors import InputError, RobotError
from gesturebank.robot import pepper
from gesturebank.robot.backends import Backend, Command, Interpolating, create
from gesturebank.robot.timeline import Timeline, from_clip, read_csv

log = logging.getLogger(__name__)

PathLike = str | os.PathLike[str]


# --------------------------------------------------------------------------------------------------
# Clocks: a real one for a robot, a virtual one (no waiting) for files


class Clock(Protocol):
    def now(self) -> float: ...

    def sleep(self, seconds: float) -> None: ...


class RealClock:
    """time.monotonic: system-wide on Linux, so other processes can compare timestamps."""

    def now(self) -> float:
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds)


class VirtualClock:
    """Time that passes only when slept: renders and logs need no real-time waiting."""

    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        return self.t

    def sleep(self, seconds: float) -> None:
        self.t += max(seconds, 0.0)


def adaptive_sleep(due: float, now: float, eta: float) -> float:
    """Sleep before sending a frame due at `due` when the clock reads `now` (Eq. 4.1):
    η·(due − now) if the frame is still ahead, else 0 (a late frame goes out at once)."""
    return eta * (due - now) if due > now else 0.0  # Eq. 4.1


# --------------------------------------------------------------------------------------------------
# Safety: pure functions over arrays


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


# --------------------------------------------------------------------------------------------------
# Audio output (real robots only; `sim` muxes the audio into its video instead)


class AudioOut(Protocol):
    def start(self) -> None: ...

    def stop(self) -> None: ...


class DeviceAudio:
    """Plays an audio file on this computer's default output (as the dissertation did)."""

    def __init__(self, path: PathLike, sample_rate: int = 48000) -> None:
        from gesturebank.extract.video import read_audio

        name = os.fspath(path)
        track = read_audio(path, sample_rate)
        if track is None:
            raise RobotError(f"{name}: no audio track to play")
        self.signal, self.rate = track.signal, track.sample_rate
        try:
            import sounddevice

            sounddevice.check_output_settings(samplerate=self.rate, channels=1)
        except Exception as exc:  # OSError: no PortAudio; PortAudioError: no device
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise RobotError(
                f"{name}: cannot play audio here: no output device ({reason})"
            ) from None
        self._sd = sounddevice

    def start(self) -> None:
        self._sd.play(self.signal, self.rate)

    def stop(self) -> None:
        self._sd.stop()


# --------------------------------------------------------------------------------------------------
# The player


@dataclass
class PlaybackResult:
    """What happened. Times are on the playback clock (0 = audio start), seconds.

    due, sent: `(K,)` when each timeline command was due and when it was handed to the backend
    (for `interpolate`, K = 1: the single call). `status` is "completed" or "interrupted".
    n_start: backend calls (send or interpolate) of the start move, before the timeline's.
    """

    status: str
    mode: str
    backend: str
    t0: float
    n_frames: int
    n_start: int = 0
    due: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sent: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def timing_ms(self) -> tuple[float, float]:
        """p50 and p99 of |sent − due| in milliseconds (client side)."""
        if not len(self.due):
            return (math.nan, math.nan)
        err = np.abs(self.sent - self.due) * 1000
        return float(np.percentile(err, 50)), float(np.percentile(err, 99))


class _Run:
    """One playback: the backend, its clock and the safety-scaled profile."""

    def __init__(
        self,
        backend: Backend,
        clock: Clock,
        config: PlaybackConfig,
        profile: pepper.RobotProfile,
    ) -> None:
        self.backend = backend
        self.clock = clock
        self.cfg = config
        self.profile = profile
        self.t0 = clock.now()
        self.last: np.ndarray | None = None
        self.calls = 0  # backend calls made so far
        self.due: list[float] = []
        self.sent: list[float] = []

    @property
    def interpolating(self) -> bool:
        return self.cfg.mode == "interpolate" and isinstance(self.backend, Interpolating)

    def current_pose(self) -> np.ndarray:
        """The robot's pose, clamped (a robot may report a hair outside its own limits)."""
        try:
            pose = self.backend.get_angles()
        except RobotError:
            if self.last is None or self.backend.connected:
                raise
            pose = self.last
        return safe_pose(pose, self.profile)

    def send(self, t: float, angles: np.ndarray, phase: str) -> None:
        cmd = Command(t=t, angles=angles, phase=phase, fraction=self.cfg.max_speed_fraction)
        self.backend.send(cmd)
        self.calls += 1
        self.last = angles

    def stream(self, times: np.ndarray, angles: np.ndarray, phase: str) -> None:
        """Send `angles[i]` at t0 + `times[i]` (playback clock), each after Eq. 4.1's sleep."""
        record = phase == "timeline"
        for t, pose in zip(times, angles, strict=True):
            self.clock.sleep(adaptive_sleep(self.t0 + t, self.clock.now(), self.cfg.eta))
            if record:
                self.due.append(float(t))
                self.sent.append(self.clock.now() - self.t0)
            self.send(float(t), pose, phase)

    def move(
        self,
        target: np.ndarray,
        phase: str,
        min_duration: float,
        t_start: float,
        start: np.ndarray | None = None,
    ) -> float:
        """Move smoothly from `start` (default: the current pose) to `target`, beginning at
        `t_start` on the playback clock; returns the playback time at which the move ends."""
        times, angles = ramp(
            self.current_pose() if start is None else start,
            target,
            profile=self.profile,
            min_duration=min_duration,
            rate_hz=self.cfg.ramp_rate_hz,
        )
        if self.interpolating:
            self.clock.sleep(t_start - (self.clock.now() - self.t0))
            assert isinstance(self.backend, Interpolating)
            self.backend.interpolate(times, angles, t=t_start, phase=phase)
            self.calls += 1
            self.last = angles[-1]
        else:
            self.stream(t_start + times, angles, phase)
        return t_start + float(times[-1])

    def frames(self, times: np.ndarray, angles: np.ndarray) -> None:
        """The timeline itself, on the playback clock (t0 = audio start)."""
        if not self.interpolating:
            self.stream(times, angles, "timeline")
            return
        assert isinstance(self.backend, Interpolating)
        self.clock.sleep(adaptive_sleep(self.t0 + times[0], self.clock.now(), 1.0))
        t_call = self.clock.now() - self.t0
        keep = times > t_call + 1e-3  # the robot already holds every earlier (past) key
        if not np.any(keep):
            return
        self.due.append(float(times[0]))
        self.sent.append(t_call)
        self.backend.interpolate(times[keep] - t_call, angles[keep], t=t_call, phase="timeline")
        self.calls += 1
        self.last = angles[-1]

    def back_to_neutral(self) -> None:
        neutral = safe_pose(pepper.neutral_pose(), self.profile)
        self.move(neutral, "return", self.cfg.return_s, self.clock.now() - self.t0)


def play(
    timeline: Timeline,
    backend: Backend,
    *,
    config: PlaybackConfig | None = None,
    profile: pepper.RobotProfile | str | None = None,
    audio: AudioOut | None = None,
    clock: Clock | None = None,
) -> PlaybackResult:
    """Play `timeline` on `backend` with the safety of the module docstring.

    Real-time backends run on the monotonic clock, others on a virtual one (no waiting).
    Returns a PlaybackResult (status "interrupted" after Ctrl-C, once back at neutral);
    raises RobotError (one line) when the robot is lost.
    """
    cfg = config or PlaybackConfig()
    if not isinstance(profile, pepper.RobotProfile):
        profile = pepper.load_profile(profile or pepper.DEFAULT_PROFILE)
    prof = speed_profile(profile, cfg.max_speed_fraction)
    clk = clock or (RealClock() if backend.realtime else VirtualClock())
    run = _Run(backend, clk, cfg, prof)
    frames = safe_angles(timeline, prof)
    status, n_start = "completed", 0
    try:
        # Schedule: move to frame 0 (ends at −lead), pause, audio at 0, frame i at times[i].
        pose = run.current_pose()
        start_times, _ = ramp(
            pose, frames[0], profile=prof, min_duration=cfg.start_s, rate_hz=cfg.ramp_rate_hz
        )
        length = float(start_times[-1])
        run.t0 = clk.now() + length + cfg.lead_s
        run.move(frames[0], "start", cfg.start_s, -cfg.lead_s - length, start=pose)
        n_start = run.calls
        clk.sleep(run.t0 - clk.now())
        if audio is not None:
            audio.start()
        run.frames(timeline.times, frames)
    except KeyboardInterrupt:
        status = "interrupted"
        log.warning("interrupted: returning to the neutral pose")
    except Exception:
        if backend.connected:
            _return_quietly(run)
        raise
    finally:
        if audio is not None:
            audio.stop()
    run.back_to_neutral()
    return PlaybackResult(
        status=status,
        mode="interpolate" if run.interpolating else "stream",
        backend=backend.name,
        t0=run.t0,
        n_frames=len(timeline),
        n_start=n_start,
        due=np.asarray(run.due),
        sent=np.asarray(run.sent),
    )


def _return_quietly(run: _Run) -> None:
    """After an error: try to go back to neutral; the original error is what the user sees."""
    try:
        run.back_to_neutral()
    except Exception as exc:
        log.warning("could not return to the neutral pose: %s", exc)


# --------------------------------------------------------------------------------------------------
# Command


def replay_command(
    angles_csv: PathLike,
    backend: str,
    url: str | None = None,
    out: PathLike | None = None,
    audio: PathLike | None = None,
    config: PlaybackConfig | None = None,
    *,
    clip: str | None = None,
    compare: PathLike | None = None,
    profile: str = pepper.DEFAULT_PROFILE,
    clamp: bool = False,
) -> PlaybackResult | Path:
    """`gesturebank replay ANGLES.csv --backend naoqi|sim|record [--url|--out] [--audio]`.

    `clip`: read the timeline from that clip of the dataset folder `angles_csv` instead.
    `compare` (sim only): a second timeline CSV rendered side by side; returns the video path.
    `clamp`: play timelines far outside the limits clamped instead of refusing them.
    An interrupted sim replay writes no video.
    """
    cfg = config or PlaybackConfig()
    robot = pepper.load_profile(profile)
    timeline = from_clip(angles_csv, clip) if clip else read_csv(angles_csv)
    name = f"{os.fspath(angles_csv)} clip {clip}" if clip else os.fspath(angles_csv)
    check_timeline(timeline, name=name, profile=robot, config=cfg, clamp=clamp)
    if compare is not None:
        if backend != "sim" or out is None:
            raise RobotError("--compare needs --backend sim and --out VIDEO.mp4")
        from gesturebank.robot.backends.sim import render_side_by_side

        other = read_csv(compare)
        check_timeline(other, name=os.fspath(compare), profile=robot, config=cfg, clamp=clamp)
        prof = speed_profile(robot, cfg.max_speed_fraction)
        return render_side_by_side(
            [timeline, other],
            [Path(angles_csv).stem, Path(compare).stem],
            out,
            profile=prof,
            audio=audio,
            fps=cfg.sim_fps,
            view_px=cfg.sim_view_px,
        )
    be = create(backend, url=url, out=out, audio=audio, config=cfg)
    try:
        sound = DeviceAudio(audio) if audio is not None and be.realtime else None
        result = play(timeline, be, config=cfg, profile=robot, audio=sound)
        if result.status == "interrupted" and be.name == "sim":
            from gesturebank.robot.backends.sim import SimBackend

            if isinstance(be, SimBackend):
                be.discard()  # its video would end early, yet look complete
    finally:
        be.close()
    p50, p99 = result.timing_ms()
    log.info(
        "%s: %d frames %s on %s (%s); send timing p50 %.2f ms, p99 %.2f ms",
        os.fspath(angles_csv),
        result.n_frames,
        result.status,
        backend,
        result.mode,
        p50,
        p99,
    )
    return result
