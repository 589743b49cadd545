"""Playback clocks: a real one for a robot, a virtual one (no waiting) for files; Eq. 4.1 sleep."""

from __future__ import annotations

import time
from typing import Protocol


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


def adaptive_sleep(due: float, now: float, *, eta: float) -> float:
    """Sleep before sending a frame due at `due` when the clock reads `now` (Eq. 4.1):
    η·(due − now) if the frame is still ahead, else 0 (a late frame goes out at once)."""
    return eta * (due - now) if due > now else 0.0  # Eq. 4.1
