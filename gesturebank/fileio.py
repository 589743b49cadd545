"""Atomic file writes: a killed process never leaves a half-written file under the final name."""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO

from gesturebank.errors import InputError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def permissions(*, folder: bool = False) -> int:
    """The mode a new file (or folder) gets from the umask: temporary files and folders are
    created private (0600 / 0700) and are given this before they replace the final name, so
    a dataset can be read by whoever the umask allows (a lab mate, a group)."""
    return (0o777 if folder else 0o666) & ~_umask()


@contextmanager
def atomic_open(path: str | os.PathLike[str]) -> Iterator[IO[bytes]]:
    """Open a temporary file beside `path` for binary writing; on success it replaces `path`.

    The temporary name starts with a dot, so folder scans that skip hidden files never see it.
    """
    final = Path(path)
    final.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=final.parent, prefix=f".{final.name}.", suffix=".tmp")
    os.chmod(tmp, permissions())
    try:
        with os.fdopen(fd, "wb") as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, final)
    except BaseException as exc:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError) and exc.filename is None:
            exc.filename = str(final)  # a failed write (e.g. a full disk) names no file
        raise


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes) -> None:
    with atomic_open(path) as f:
        f.write(data)


@contextmanager
def atomic_folder(path: str | os.PathLike[str]) -> Iterator[Path]:
    """A temporary folder beside `path` to fill; on success it replaces `path` whole.

    Nothing of an older `path` survives (no stale file), and a failure or Ctrl-C leaves the
    old folder as it was. POSIX cannot swap two folders in one step: the old one is renamed
    aside, the new one into place, then the old one is deleted.
    """
    final = Path(path)
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=final.parent, prefix=f".{final.name}.", suffix=".tmp"))
    try:
        yield tmp
        os.chmod(tmp, permissions(folder=True))
        old = None
        if final.exists():
            # renaming a folder onto an empty one is allowed, so mkdtemp reserves a unique name
            old = Path(tempfile.mkdtemp(dir=final.parent, prefix=f".{final.name}.", suffix=".old"))
            os.replace(final, old)
        try:
            os.replace(tmp, final)
        except BaseException:
            if old is not None:
                os.replace(old, final)
            raise
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


@contextmanager
def output_errors(path: str | os.PathLike[str], what: str) -> Iterator[None]:
    """Turn an OSError while writing `what` to `path` into a one-line InputError naming it."""
    try:
        yield
    except FileExistsError as exc:  # mkdir where a file is: "File exists" would puzzle
        raise InputError(f"{path}: cannot write {what} ({exc.filename} is not a folder)") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot write {what} ({exc.strerror or exc})") from None


def sha256_file(path: str | os.PathLike[str]) -> str:
    """Hex sha256 of a file's bytes, read in 1 MiB blocks."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def keep_existing(paths: Iterable[str | os.PathLike[str]], *, force: bool) -> None:
    """The one overwrite policy of the commands that write an output: unless `force`, an
    InputError naming the first of `paths` that exists (a folder: one that holds anything), so
    a second run never replaces a model or a video without a word."""
    if force:
        return
    for path in map(Path, paths):
        if path.is_dir() and not any(path.iterdir()):
            continue  # an empty folder holds nothing to lose
        if path.exists():
            raise InputError(f"{path}: already exists and is kept; --force replaces it")
