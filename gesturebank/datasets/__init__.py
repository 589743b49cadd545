"""Datasets: finding takes, building them, the on-disk format, splits and loaders."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gesturebank.datasets.reader import Dataset


def open(  # shadows builtins.open on purpose
    path: str | os.PathLike[str], *, require: str | None = None
) -> Dataset:
    """Open a dataset folder written by `build-dataset`; takes are loaded lazily. `require`:
    body parts every listed clip must have ("head", "arms", "head+left_arm", ...; see
    `clip.PART_LABELS`), e.g. "arms" for an arm model; None lists every clip."""
    from gesturebank.datasets.reader import Dataset

    return Dataset(path, require=require)
