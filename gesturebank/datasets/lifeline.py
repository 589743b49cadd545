"""Pool workers die with the build that started them.

A forkserver worker's parent is the fork server, not the build, and both hold pipes that keep
each other alive: after a SIGKILL of the build they would finish their takes into OUT_DIR
(whose lock is already released) and then idle. So each worker watches the build's pid itself
and kills itself when the build is gone; the fork server exits once its last worker has.
"""

from __future__ import annotations

import os
import select
import threading
import time
from typing import NoReturn

POLL_S = 1.0  # only where there is no pidfd (not Linux ≥ 5.3)


def die_with(pid: int) -> None:
    """Worker initialiser: end this process as soon as process `pid` has exited."""
    try:
        fd: int | None = os.pidfd_open(pid)
    except ProcessLookupError:  # gone already
        _die()
    except (AttributeError, OSError):
        fd = None
    threading.Thread(target=_watch, args=(pid, fd), name="lifeline", daemon=True).start()


def _watch(pid: int, fd: int | None) -> None:
    if fd is not None:
        select.select([fd], [], [])  # a pidfd becomes readable when its process exits
    else:
        while _alive(pid):
            time.sleep(POLL_S)
    _die()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, PermissionError):  # gone, or the pid reused by another user
        return False
    return True


def _die() -> NoReturn:
    # at once, from any thread, no clean-up: a half-written take stays under its temporary
    # name, which the next build removes
    os._exit(1)
