"""Where a detection has got to in its video, for whoever watches (the build's progress).

`watching(callback)` around any detection calls `callback(t)` with the source time (s) of every
frame the detector is given, in the detecting thread. Nothing is called outside it; the callback
must be cheap (it runs once a frame): the build's stores a float.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

FrameCallback = Callable[[float], None]

_WATCHER: ContextVar[FrameCallback | None] = ContextVar("frame_watcher", default=None)


@contextmanager
def watching(callback: FrameCallback) -> Iterator[None]:
    """Inside, every frame detected in this thread calls `callback(frame time, s)`."""
    token = _WATCHER.set(callback)
    try:
        yield
    finally:
        _WATCHER.reset(token)


def watcher() -> FrameCallback | None:
    """The callback of the `watching` around this call, if any."""
    return _WATCHER.get()
