"""One writer per dataset folder: `build-dataset` and `gesturebank qc` hold OUT_DIR/.lock.

The lock is `fcntl.flock` on an open file, so the kernel releases it when its holder dies in
any way (SIGKILL included): a lock file left by a dead process is simply taken over. The
holder's pid is written into the file only to name it in the message a second writer gets.
The file is never deleted: unlinking it would let two writers lock two different files.
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from gesturebank.errors import InputError

LOCK_FILE = ".lock"


@contextmanager
def dataset_lock(out: Path) -> Iterator[None]:
    """Hold the exclusive lock of the dataset folder `out` (which must exist) while inside.

    Raises InputError naming the holder's pid when another process holds it.
    """
    path = Path(out) / LOCK_FILE
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
    except OSError as exc:
        raise InputError(f"{path}: cannot open the dataset's lock file ({exc.strerror})") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
            raise InputError(
                f"{out}: another gesturebank process (pid {holder}) is writing this dataset; "
                "wait for it to finish or stop it"
            ) from None
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        except OSError:  # e.g. a full disk: the pid only names the holder, the lock holds
            pass
        yield
    finally:
        os.close(fd)  # releases the lock
