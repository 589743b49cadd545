"""A short stretch of the bvhtools test take, as the renders' tests use it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturebank.config import MocapConfig, SynthConfig
from gesturebank.footage import SPEECH
from gesturebank.testing.mocap import BVH

START_S = 31.0  # the stretch starts here


@pytest.fixture(scope="session")
def test_bvh(samples: Path) -> Path:
    return samples / BVH


@pytest.fixture(scope="session")
def speech(samples: Path) -> list[Path]:
    return [samples / rel for rel in SPEECH]


@pytest.fixture(scope="session")
def stretch_joints(test_bvh: Path) -> np.ndarray:
    """(5, 17, 3) joints, a frame every 0.3 s from 31 s."""
    from gesturebank.synth.take import stretch

    config = SynthConfig(start_s=START_S, length_s=1.5, rate_fps=10 / 3)
    _, joints = stretch(test_bvh, config=config, mocap=MocapConfig())
    return joints
