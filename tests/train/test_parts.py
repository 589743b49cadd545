"""Body parts a model's clips must have (issue 32): the closed vocabulary of the manifest's
`parts`, the default from a model's targets, and `train --require` recorded in model.json."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gesturebank.cli.training import train_command
from gesturebank.clip import PART_JOINTS, PART_LABELS, PARTS, parse_parts, parts_label, parts_of
from gesturebank.config import TrainConfig
from gesturebank.errors import InputError
from gesturebank.robot.pepper import INDEX, JOINTS
from gesturebank.train.parts import default_require

ONE_EPOCH = TrainConfig.model_validate({"mlp": {"max_epochs": 1}})


def test_every_set_of_parts_has_one_label_that_reads_back() -> None:
    assert len(PART_LABELS) == 2 ** len(PARTS) and len(set(PART_LABELS.values())) == 8
    for parts, label in PART_LABELS.items():
        assert parts_label(parts) == label and parse_parts(label) == parts
    assert parse_parts("arms+head") == parse_parts("head+left_arm+right_arm") == set(PARTS)
    for bad in ("hands", "head+tail", "none+head", ""):
        with pytest.raises(InputError, match="body parts"):
            parse_parts(bad)


def test_the_parts_of_a_mask_are_the_parts_with_a_known_angle() -> None:
    mask = np.zeros((10, len(JOINTS)), bool)
    mask[3, INDEX["HeadYaw"]] = mask[:, INDEX["HipRoll"]] = True  # HipRoll is no part
    assert parts_label(parts_of(mask)) == "head"
    mask[:, INDEX["RElbowRoll"]] = True
    assert parts_label(parts_of(mask)) == "head+right_arm"


def test_a_models_clips_need_the_parts_it_predicts() -> None:
    assert default_require(JOINTS) is None  # the whole body: every clip, unknown joints masked
    assert default_require(PART_JOINTS["head"]) == "head"
    assert default_require(PART_JOINTS["left_arm"] + PART_JOINTS["right_arm"]) == "arms"
    assert default_require(("HeadYaw", "LElbowRoll", "HipRoll")) == "head+left_arm"


def test_train_require_is_recorded_in_model_json(synthetic_dataset: Path, tmp_path: Path) -> None:
    out = tmp_path / "m"
    train_command(
        synthetic_dataset,
        model="mlp",
        variant="si",
        fold=0,
        subject=None,
        out_dir=out,
        config=ONE_EPOCH,
        quiet=True,
    )
    assert json.loads((out / "model.json").read_text())["require"] is None
    train_command(
        synthetic_dataset,
        model="mlp",
        variant="si",
        fold=0,
        subject=None,
        out_dir=out,
        config=ONE_EPOCH,
        quiet=True,
        require="arms+head",
    )
    assert json.loads((out / "model.json").read_text())["require"] == "head+arms"
