"""`naoqi` backend: a real Pepper (or anything serving ALMotion) over libqi, `tcp://HOST:9559`.

Calls used: `setAngles(names, angles, fractionMaxSpeed)` (non-blocking on the robot),
`angleInterpolation(names, angleLists, timeLists, isAbsolute)` (blocking for the motion's length),
`getAngles(names, useSensors)`, `wakeUp()` and optionally `rest()`. Every call goes out
asynchronously and is awaited with a timeout, so a robot that silently vanishes (Wi-Fi) is
detected like one that closes the socket. Errors are one line (RobotError) naming the URL.
"""

from __future__ import annotations

import logging
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from gesturebank.config import PlaybackConfig
from gesturebank.errors import InputError, RobotError
from gesturebank.robot.backends import Command
from gesturebank.robot.pepper import JOINTS

if TYPE_CHECKING:
    from gesturebank.config import PlaybackConfig

log = logging.getLogger(__name__)

_POLL_MS = 50  # blocking calls are awaited in slices so that Ctrl-C gets through


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


class NaoqiBackend:
    """ALMotion of the robot at `url`; connects on construction (RobotError if it cannot)."""

    name = "naoqi"
    realtime = True

    def __init__(self, url: str, *, config: PlaybackConfig | None = None) -> None:
        """config: the `playback` section (timeout_s, wake_up, rest_at_end); None: defaults."""
        cfg = config or PlaybackConfig()
        timeout_s, wake_up, rest_at_end = cfg.timeout_s, cfg.wake_up, cfg.rest_at_end
        try:
            import qi
        except ImportError as exc:
            raise RobotError(f"{url}: the qi package is not installed ({exc})") from None
        qi.logging.setLevel(qi.logging.ERROR)  # keep libqi's chatter off the one-line errors
        self.url = url
        self.timeout_ms = int(timeout_s * 1000)
        self.rest_at_end = rest_at_end
        self._lost = False
        self._names = list(JOINTS)
        self.session = qi.Session()
        try:
            self.session.connect(url, _async=True).value(self.timeout_ms)
            self.motion: Any = self.session.service("ALMotion")
        except RuntimeError as exc:
            self._close_session()
            raise RobotError(f"{url}: cannot connect to ALMotion ({_first_line(exc)})") from None
        if wake_up:
            self._call("wakeUp", timeout_ms=self.timeout_ms + 30_000)  # standing up takes a while

    @property
    def connected(self) -> bool:
        return not self._lost and bool(self.session.isConnected())

    def _fail(self, method: str, exc: BaseException) -> RobotError:
        msg = _first_line(exc)
        if not self.session.isConnected() or "not connected" in msg or "disconnected" in msg:
            self._lost = True
            return RobotError(f"{self.url}: connection to the robot lost during {method} ({msg})")
        if "timeout" in msg.lower():
            self._lost = True
            return RobotError(
                f"{self.url}: ALMotion.{method} got no answer within "
                f"{self.timeout_ms / 1000:g} s; connection lost"
            )
        return RobotError(f"{self.url}: ALMotion.{method} failed ({msg})")

    def _call(self, method: str, *args: Any, timeout_ms: int | None = None) -> Any:
        if self._lost:
            raise RobotError(f"{self.url}: connection to the robot lost")
        try:
            future = getattr(self.motion, method)(*args, _async=True)
            return future.value(timeout_ms or self.timeout_ms)
        except (RuntimeError, AttributeError) as exc:
            raise self._fail(method, exc) from None

    def get_angles(self) -> np.ndarray:
        values = self._call("getAngles", self._names, True)  # useSensors: the real pose
        pose = np.asarray(values, dtype=np.float32)
        if pose.shape != (len(JOINTS),):
            raise RobotError(f"{self.url}: getAngles returned {pose.shape}, expected 11 angles")
        return pose

    def send(self, cmd: Command) -> None:
        angles = [float(a) for a in cmd.angles]
        self._call("setAngles", self._names, angles, float(cmd.fraction))

    def interpolate(self, times: np.ndarray, angles: np.ndarray, *, t: float, phase: str) -> None:
        key_times = [float(x) for x in times]
        angle_lists = [[float(a) for a in col] for col in np.asarray(angles).T]
        args = (self._names, angle_lists, [key_times] * len(JOINTS), True)
        if self._lost:
            raise RobotError(f"{self.url}: connection to the robot lost")
        try:
            future = self.motion.angleInterpolation(*args, _async=True)
        except RuntimeError as exc:
            raise self._fail("angleInterpolation", exc) from None
        deadline = time.monotonic() + key_times[-1] + self.timeout_ms / 1000
        try:
            while not future.isFinished():
                if time.monotonic() > deadline:
                    raise self._fail("angleInterpolation", RuntimeError("timeout"))
                future.wait(_POLL_MS)
        except KeyboardInterrupt:
            self._stop_motion()
            raise
        if future.hasError():
            raise self._fail("angleInterpolation", RuntimeError(future.error()))

    def _stop_motion(self) -> None:
        """Stop a running angleInterpolation (best effort) so the return move can take over."""
        try:
            self._call("killTasksUsingResources", self._names)
        except RobotError as exc:
            log.warning("%s", exc)

    def close(self) -> None:
        if self.rest_at_end and self.connected:
            try:
                self._call("rest", timeout_ms=self.timeout_ms + 30_000)
            except RobotError as exc:
                log.warning("%s", exc)
        self._close_session()

    def _close_session(self) -> None:
        try:
            self.session.close()
        except RuntimeError:
            pass


def create(
    *,
    url: str | None = None,
    out: str | None = None,
    audio: str | None = None,
    config: PlaybackConfig | None = None,
) -> NaoqiBackend:
    if not url:
        raise InputError("--backend naoqi needs --url tcp://HOST:9559")
    return NaoqiBackend(url, config=config)
