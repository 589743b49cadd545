"""Datasets: finding takes, building them, the on-disk format, splits and loaders."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gesturebank.datasets.store import Dataset


def open(path: str | os.PathLike[str]) -> Dataset:  # shadows builtins.open on purpose
    """Open a dataset folder written by `build-dataset`; takes are loaded lazily."""
    from gesturebank.datasets.store import Dataset

    return Dataset(path)
