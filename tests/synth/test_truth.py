"""The truth's loader and the looks: bad folders are one line naming the file; every look the
config accepts exists."""

from __future__ import annotations

from pathlib import Path
from typing import get_args

import numpy as np
import pytest

from gesturebank.config import SynthLook
from gesturebank.errors import InputError
from gesturebank.synth.looks import LOOKS, background
from gesturebank.synth.truth import Truth


def test_every_configurable_look_exists() -> None:
    assert set(get_args(SynthLook)) == set(LOOKS)
    for look in LOOKS.values():
        wall = background(look, size=(64, 48))
        assert wall.shape == (48, 64, 3) and 0 <= wall.min() and wall.max() <= 1


def test_a_folder_without_truth_is_one_line_naming_the_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=str(tmp_path / "truth.npz")):
        Truth.load(tmp_path)


def test_a_truth_missing_an_array_is_one_line_naming_it(tmp_path: Path) -> None:
    (tmp_path / "calibration.toml").write_text(
        '[cam01]\nname = "cam01"\nsize = [64.0, 48.0]\n'
        "matrix = [[50.0, 0.0, 31.5], [0.0, 50.0, 23.5], [0.0, 0.0, 1.0]]\n"
        "distortions = []\nrotation = [0.0, 0.0, 0.0]\ntranslation = [0.0, 0.0, 3.0]\n"
    )
    np.savez(tmp_path / "truth.npz", times=np.zeros(2), cameras=np.array(["cam01"]))
    with pytest.raises(InputError, match="truth.npz: missing joints3d"):
        Truth.load(tmp_path)
