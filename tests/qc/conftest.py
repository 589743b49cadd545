"""Fixtures of the QC tests: a clean synthetic clip and the small real dataset of the session."""

from __future__ import annotations

from pathlib import Path

import pytest

from gesturebank.clip import Clip
from gesturebank.testing.clips import synthetic_clip


@pytest.fixture()
def clip() -> Clip:
    return synthetic_clip()


@pytest.fixture(scope="session")
def real_dataset(demo_dataset: Path) -> Path:
    """The demo videos of `samples/talking` built with the default config (tests/conftest.py)."""
    return demo_dataset
