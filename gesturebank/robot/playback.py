"""The player: plays an angle timeline on a backend, safely, in sync with its audio.

Safety, on every backend (the backends only translate):
- every angle sent is clamped into the robot profile's limits and every joint's speed stays
  below `max_speed_fraction` × its maximum velocity (`gesturebank.robot.safety`);
- playback starts by moving smoothly from the robot's current pose (read from it) to frame 0,
  and ends — normally, on Ctrl-C, or on an error — by moving smoothly back to the neutral pose;
- a lost connection stops playback with one line (RobotError) instead of a traceback.

Timing: frame i of the timeline is due at t0 + times[i], where t0 is the moment the audio starts:
as the audio output reports it when it can (the robot's own speaker), else when it was started.
Two modes (`PlaybackConfig.mode`):
- `stream`: one setAngles per frame, each preceded by the adaptive sleep of Eq. 4.1;
- `interpolate`: one time-stamped call for the whole timeline (ALMotion angleInterpolation),
  where the backend supports it.
The default is the mode that kept better sync in `benchmarks/playback.py` (see its docstring).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from gesturebank.config import PlaybackConfig
from gesturebank.errors import RobotError
from gesturebank.robot import pepper
from gesturebank.robot.audio_out import AudioOut
from gesturebank.robot.backends import Backend, Command, Interpolating
from gesturebank.robot.clock import Clock, RealClock, VirtualClock, adaptive_sleep
from gesturebank.robot.safety import ramp, safe_angles, safe_pose, speed_profile
from gesturebank.robot.timeline import Timeline

log = logging.getLogger(__name__)


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


class Player:
    """One playback on `backend`: its clock, the config and the speed-scaled `profile`.

    `t0` is the clock reading at playback time 0 (the audio's start); `move`, `frames` and
    `back_to_neutral` send through the backend on that clock; `last` is the last pose sent.
    `play` uses it for a timeline, live mode (`online.run_live`) for its start and return moves.
    """

    def __init__(
        self,
        backend: Backend,
        *,
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
            self.clock.sleep(adaptive_sleep(self.t0 + t, self.clock.now(), eta=self.cfg.eta))
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
        self.clock.sleep(adaptive_sleep(self.t0 + times[0], self.clock.now(), eta=1.0))
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
    run = Player(backend, clock=clk, config=cfg, profile=prof)
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
            started = audio.start()
            if started is not None:  # the device reported when its sound began: time from it
                run.t0 = started
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


def _return_quietly(run: Player) -> None:
    """After an error: try to go back to neutral; the original error is what the user sees."""
    try:
        run.back_to_neutral()
    except Exception as exc:
        log.warning("could not return to the neutral pose: %s", exc)
