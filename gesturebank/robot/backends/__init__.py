"""Robot backends: where the player's commands go (a real Pepper, a video, a log).

A backend is a small object with `get_angles`, `send`, `close` (and optionally `interpolate`).
Every command it receives has already passed the player's safety (limits, velocity), so a backend
only translates. Built-ins register lazily so that listing names imports neither qi nor PyAV:

- `naoqi`:  ALMotion over qi (`url` = tcp://HOST:9559);
- `sim`:    renders Pepper's kinematic model to an MP4 with the audio muxed in (`out`);
- `record`: writes every command as one JSON line (`out`).

A factory is called as `factory(url=..., out=..., audio=..., config=PlaybackConfig)`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from gesturebank.registry import Registry

PHASES = ("start", "timeline", "return", "live")


@dataclass(frozen=True, eq=False)
class Command:
    """One pose to send now.

    t:        seconds on the playback clock (0 = audio start; negative during the start move).
    angles:   (11,) float32 rad in `pepper.JOINTS` order, already within limits and speed.
    phase:    one of `PHASES`.
    fraction: ALMotion's fractionMaxSpeed for this command (0, 1].
    """

    t: float
    angles: np.ndarray
    phase: str
    fraction: float


@runtime_checkable
class Backend(Protocol):
    """What the player needs from a robot (or a stand-in for one)."""

    name: str
    realtime: bool  # True: commands must leave at their due wall-clock time (a real robot)

    @property
    def connected(self) -> bool:
        """False once the link to the robot is known to be lost (nothing more can be sent)."""
        ...

    def get_angles(self) -> np.ndarray:
        """Current commanded pose `(11,)` float32 rad."""
        ...

    def send(self, cmd: Command) -> None:
        """Send one pose; RobotError (one line) if the robot cannot be reached."""
        ...

    def close(self) -> None:
        """Release the connection / finish the output file."""
        ...


@runtime_checkable
class Interpolating(Backend, Protocol):
    """A backend that can play a whole time-stamped trajectory in one call (ALMotion-style)."""

    def interpolate(self, times: np.ndarray, angles: np.ndarray, *, t: float, phase: str) -> None:
        """Blocking: reach `angles[k] (N, 11)` at `times[k] (N,)` s after the call (> 0, rising).

        `t` is the playback-clock time of the call (for logs). KeyboardInterrupt stops the motion.
        """
        ...


BACKENDS: Registry[Backend] = Registry("robot backend", "gesturebank.robot_backends")
BACKENDS.register_lazy("naoqi", "gesturebank.robot.backends.naoqi:create")
BACKENDS.register_lazy("sim", "gesturebank.robot.backends.sim:create")
BACKENDS.register_lazy("record", "gesturebank.robot.backends.record:create")


def available() -> list[str]:
    """Names accepted by `create`."""
    return BACKENDS.names()


def create(name: str, **kwargs: object) -> Backend:
    """The backend `name`, built with keyword options (url, out, audio, config)."""
    return BACKENDS.create(name, **kwargs)
