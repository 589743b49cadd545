"""`naoqi` backend: a real Pepper (or anything serving ALMotion) over libqi, `tcp://HOST:9559`.

Calls used: `setAngles(names, angles, fractionMaxSpeed)` (non-blocking on the robot),
`angleInterpolation(names, angleLists, timeLists, isAbsolute)` (blocking for the motion's length),
`getAngles(names, useSensors)`, `wakeUp()` and optionally `rest()`. Every call goes out
asynchronously and is awaited with a timeout, so a robot that silently vanishes (Wi-Fi) is
detected like one that closes the socket. Errors are one line (RobotError) naming the URL.

Sound (`--audio F`) plays on the robot, over the same qi session: the file is decoded here and
streamed as PCM with `ALAudioDevice.sendRemoteBufferToOutput(nbOfFrames, buffer)` (16-bit
interleaved stereo at 48 kHz, 0.1 s a call). Streaming rather than uploading the file for
`ALAudioPlayer`: NAOqi has no qi service that writes a file on the robot (that takes ssh/scp),
and streaming needs nothing installed there. The robot answers the first buffer once its output
has taken it, and that answer is the sound's start: the motion's clock starts from it, so a
slow-to-open output delays the motion with the sound instead of leaving them apart. What it
adds is the first buffer's trip (19.2 kB: a few ms on a LAN, tens on a busy Wi-Fi) plus however
long the robot's output takes to open; the motion waits for both. The stream then keeps
`AHEAD_S` of sound queued ahead of the speaker, so the network's jitter never starves it.
"""

from __future__ import annotations

import logging
import os
import threading
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
SAMPLE_RATE = 48000  # ALAudioDevice's output rate (its default)
CHUNK_FRAMES = 4800  # 0.1 s of sound a call (NAOqi takes at most 16384 frames)
AHEAD_S = 0.3  # sound queued on the robot ahead of what it plays: covers Wi-Fi jitter


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def stereo_pcm(signal: np.ndarray) -> bytes:
    """Mono float samples in [-1, 1] as ALAudioDevice takes them: 16-bit little-endian,
    left and right interleaved (the same sample on both)."""
    mono = (np.clip(np.asarray(signal, np.float64), -1, 1) * 32767).round().astype("<i2")
    return np.repeat(mono, 2).tobytes()


class RobotSpeaker:
    """Plays an audio file on the robot's loudspeakers by streaming it to ALAudioDevice
    (module docstring). `start` returns when the robot reports the sound has started."""

    def __init__(self, device: Any, path: str | os.PathLike[str], *, url: str, timeout_ms: int):
        from gesturebank.audio.io import read_audio

        track = read_audio(path, sample_rate=SAMPLE_RATE)
        if track is None or not len(track.signal):
            raise RobotError(f"{os.fspath(path)}: no audio track to play on the robot")
        self.device, self.url, self.timeout_ms = device, url, timeout_ms
        self.pcm = stereo_pcm(track.signal)
        self.started_at: float | None = None
        self._started = threading.Event()
        self._stop = threading.Event()
        self._error: str | None = None
        self._thread: threading.Thread | None = None

    def start(self) -> float:
        """Start streaming; returns the time.monotonic() at which the robot's sound began."""
        self._thread = threading.Thread(target=self._stream, name="robot-speaker", daemon=True)
        self._thread.start()
        if not self._started.wait(self.timeout_ms / 1000 + 1):
            self._error = self._error or f"no answer within {self.timeout_ms / 1000:g} s"
        if self._error is not None or self.started_at is None:
            self.stop()
            raise RobotError(f"{self.url}: ALAudioDevice could not play the audio ({self._error})")
        return self.started_at

    def _stream(self) -> None:
        frames = len(self.pcm) // 4
        for first in range(0, frames, CHUNK_FRAMES):
            if self.started_at is not None:  # keep AHEAD_S queued, not the whole file
                due = self.started_at + first / SAMPLE_RATE - AHEAD_S
                if self._stop.wait(max(0.0, due - time.monotonic())):
                    return
            if self._stop.is_set():
                return
            n = min(CHUNK_FRAMES, frames - first)
            chunk = self.pcm[4 * first : 4 * (first + n)]
            try:
                self.device.sendRemoteBufferToOutput(n, chunk, _async=True).value(self.timeout_ms)
            except RuntimeError as exc:
                self._error = _first_line(exc)
                self._started.set()  # wakes `start` if it still waits
                return
            if self.started_at is None:
                self.started_at = time.monotonic()  # the robot's answer: its sound has begun
                self._started.set()

    def stop(self) -> None:
        """Send no more (what the robot holds, at most AHEAD_S, still plays out)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=self.timeout_ms / 1000 + 1)


class NaoqiBackend:
    """ALMotion of the robot at `url`; connects on construction (RobotError if it cannot)."""

    name = "naoqi"
    realtime = True

    def __init__(
        self,
        url: str,
        *,
        config: PlaybackConfig | None = None,
        audio: str | os.PathLike[str] | None = None,
    ) -> None:
        """config: the `playback` section (timeout_s, wake_up, rest_at_end); None: defaults.
        audio: a file the robot plays (`speaker`), streamed to its ALAudioDevice."""
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
        self.speaker: RobotSpeaker | None = None
        if audio is not None:
            try:
                device = self.session.service("ALAudioDevice")
            except RuntimeError as exc:
                self._close_session()
                msg = _first_line(exc)
                raise RobotError(f"{url}: no ALAudioDevice to play the audio ({msg})") from None
            try:
                self.speaker = RobotSpeaker(device, audio, url=url, timeout_ms=self.timeout_ms)
            except RobotError:
                self._close_session()
                raise
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
    return NaoqiBackend(url, config=config, audio=audio)
