"""One writer per dataset folder: `build-dataset` and `gesturebank qc` hold OUT_DIR/.lock.

The lock is `fcntl.flock` on an open file, so the kernel releases it when its holder dies in
any way (SIGKILL included): a lock file left by a dead process is simply taken over. The
holder's pid is written into the file only to name it in the message a second writer gets.
A holder that finishes removes the file while it still holds the lock, so a finished dataset
holds no `.lock`; a writer that locked a file removed that way (its inode is no longer the
path's) opens the path again, so two writers never hold two different files.
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
    fd = _locked(path, out)
    try:
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        except OSError:  # e.g. a full disk: the pid only names the holder, the lock holds
            pass
        yield
    finally:
        try:
            path.unlink(missing_ok=True)  # still held: nobody can be inside with this file
        except OSError:  # a read-only folder now: the file stays, the lock is released anyway
            pass
        os.close(fd)  # releases the lock


def _locked(path: Path, out: Path) -> int:
    """An fd holding the exclusive flock of the file now at `path` (module docstring)."""
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
        except OSError as exc:
            raise InputError(
                f"{path}: cannot open the dataset's lock file ({exc.strerror})"
            ) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise InputError(
                f"{out}: another gesturebank process (pid {holder}) is writing this dataset; "
                "wait for it to finish or stop it"
            ) from None
        try:
            same = os.stat(path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            return fd
        os.close(fd)  # its holder removed it as it finished: lock the path's file anew
