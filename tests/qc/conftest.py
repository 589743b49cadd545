"""Fixtures of the QC tests: a synthetic take and the small real dataset of the session."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from qc_data import synthetic_take


@pytest.fixture()
def take() -> dict[str, np.ndarray]:
    return synthetic_take()


@pytest.fixture(scope="session")
def real_dataset(demo_dataset: Path) -> Path:
    """The 3 demo videos of `samples/talking` built with the default config (tests/conftest.py)."""
    return demo_dataset
