"""Detection cache: raw detector output and shot cuts keyed by (video content, detector name +
settings).

Rebuilding a dataset with another lifter or other filters reuses the detections. Entries are
`<key>.npz` files (no pickle) written atomically (temporary file in the same folder, fsync,
os.replace), so a killed run never leaves a half-written entry, and concurrent workers at worst
compute the same entry twice.

Video identity is `video_digest`: sha256 over the file size, the first and last MiB and 16
evenly spaced 64 KiB blocks. It reads ≤ 3 MiB whatever the file size, so a cache hit on a long
video costs milliseconds instead of reading gigabytes (benchmarks/extract.py measures both).
Compressed video leaves no realistic chance that two different files agree on size and on all
sampled blocks; `full=True` hashes every byte for callers who want that guarantee.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from platformdirs import user_cache_dir

from gesturebank.errors import InputError
from gesturebank.extract.shots import Shots
from gesturebank.fileio import atomic_open
from gesturebank.poses import MultiPose2D

log = logging.getLogger(__name__)

ENV = "GESTUREBANK_CACHE"
FORMAT = 2  # bump when the stored arrays change meaning (2: track ids and shots)
_SHOTS = "shots_"
_HEAD = _TAIL = 1 << 20
_BLOCK = 64 << 10
_N_BLOCKS = 16


def default_cache_dir() -> Path:
    """$GESTUREBANK_CACHE if set, else `<user cache dir>/gesturebank/detections`."""
    env = os.environ.get(ENV)
    return Path(env) if env else Path(user_cache_dir("gesturebank")) / "detections"


def video_digest(path: str | os.PathLike[str], *, full: bool = False) -> str:
    """Hex sha256 identifying a video's content (sampled by default, see module docstring)."""
    name = os.fspath(path)
    h = hashlib.sha256()
    try:
        with open(name, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            h.update(f"{size}:{'full' if full else 'sampled'}".encode())
            if full or size <= _HEAD + _TAIL + _N_BLOCKS * _BLOCK:
                for chunk in iter(lambda: f.read(1 << 20), b""):
                    h.update(chunk)
            else:
                for offset, length in _sample_spans(size):
                    f.seek(offset)
                    h.update(f.read(length))
    except OSError as exc:
        raise InputError(f"{name}: cannot read file ({exc.strerror or exc})") from None
    return h.hexdigest()


def _sample_spans(size: int) -> list[tuple[int, int]]:
    """(offset, length) of the head, evenly spaced inner blocks, and the tail."""
    inner = np.linspace(_HEAD, size - _TAIL - _BLOCK, _N_BLOCKS).astype(np.int64)
    return [(0, _HEAD), *((int(o), _BLOCK) for o in inner), (size - _TAIL, _TAIL)]


def cache_key(digest: str, detector: str, *, params: Mapping[str, Any]) -> str:
    """Hex key of one detection run: video digest, detector name and every setting that matters."""
    blob = json.dumps(
        {"format": FORMAT, "video": digest, "detector": detector, "params": params},
        sort_keys=True,
        default=str,
    )
    return hashlib.sha256(blob.encode()).hexdigest()[:32]


class DetectionCache:
    """A folder of `<key>.npz` detection results."""

    def __init__(self, root: str | os.PathLike[str] | None = None) -> None:
        self.root = Path(root) if root is not None else default_cache_dir()

    def path(self, key: str) -> Path:
        return self.root / f"{key}.npz"

    def load(self, key: str) -> tuple[MultiPose2D, Shots] | None:
        """The cached result, or None when absent or unreadable (a bad entry is removed)."""
        path = self.path(key)
        if not path.is_file():
            return None
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files}
            shots = {k[len(_SHOTS) :]: v for k, v in arrays.items() if k.startswith(_SHOTS)}
            multi = {k: v for k, v in arrays.items() if not k.startswith(_SHOTS)}
            return MultiPose2D.from_arrays(multi), Shots.from_arrays(shots)
        except (OSError, ValueError, KeyError, EOFError, InputError) as exc:
            log.warning("%s: unreadable cache entry dropped (%s)", path, exc)
            path.unlink(missing_ok=True)
            return None

    def save(self, key: str, multi: MultiPose2D, shots: Shots) -> Path:
        """Write atomically; returns the entry's path."""
        final = self.path(key)
        arrays: dict[str, Any] = multi.to_arrays()
        arrays.update({f"{_SHOTS}{k}": v for k, v in shots.to_arrays().items()})
        with atomic_open(final) as f:
            np.savez(f, allow_pickle=False, **arrays)
        return final

    def entries(self) -> list[Path]:
        """The cache's entries (`<key>.npz`), none when the folder does not exist."""
        return sorted(self.root.glob("*.npz")) if self.root.is_dir() else []

    def clear(self) -> tuple[int, int]:
        """Remove every entry; returns (entries removed, bytes freed). Only `<key>.npz` files
        go: anything else a user put in the folder stays."""
        removed = freed = 0
        for entry in self.entries():
            size = entry.stat().st_size
            entry.unlink(missing_ok=True)
            removed, freed = removed + 1, freed + size
        return removed, freed
