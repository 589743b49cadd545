"""The model folder has one reader: training, evaluation and live mode see the same folder."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from gesturebank.app.robot import load_frame_model
from gesturebank.cli.training import train_command
from gesturebank.config import TrainConfig
from gesturebank.errors import InputError
from gesturebank.robot import pepper
from gesturebank.train import model_folder

ONE_EPOCH = TrainConfig.model_validate({"lstm": {"max_epochs": 1}})


def test_train_evaluate_and_live_read_the_same_folder(
    synthetic_dataset: Path, tmp_path: Path
) -> None:
    out = tmp_path / "lstm"
    train_command(
        synthetic_dataset,
        model="lstm",
        variant="si",
        fold=0,
        subject=None,
        out_dir=out,
        config=ONE_EPOCH,
        quiet=True,
    )
    folder = model_folder.load(out)
    assert folder.graph == out / model_folder.STEP_ONNX  # live mode steps the LSTM
    # The limits stored with the model are the named profile's, to the bit: live mode (which
    # read the profile by name before) and evaluate/synthesize (the stored limits) agree.
    named = pepper.load_profile(folder.profile.name)
    for k in ("lower", "upper", "velocity"):
        np.testing.assert_array_equal(getattr(folder.profile, k), getattr(named, k))
    live = load_frame_model(out, znorm="s1")
    assert live.profile == folder.profile.name
    np.testing.assert_array_equal(live.robot.velocity, folder.profile.velocity)
    mean, std = folder.znorm("s1")
    np.testing.assert_array_equal(live.audio_mean, mean)
    np.testing.assert_array_equal(live.audio_std, std)
    assert live.audio == folder.audio and folder.train_config == ONE_EPOCH
    saved = torch.load(out / model_folder.WEIGHTS, weights_only=True)
    net = folder.torch_model()
    assert all(torch.equal(saved[k], v) for k, v in net.state_dict().items())


def test_bad_folders_and_graphs_are_one_line(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="model.onnx: missing") as info:
        model_folder.load(tmp_path)
    assert "\n" not in str(info.value)
    (tmp_path / model_folder.MODEL_ONNX).write_text("not a graph")
    (tmp_path / model_folder.MODEL_JSON).write_text("{")
    (tmp_path / model_folder.NORMALISERS).write_text("{}")
    with pytest.raises(InputError, match="unreadable model.json or normalisers.json"):
        model_folder.load(tmp_path)
    with pytest.raises(InputError, match="not a loadable ONNX model") as info:
        model_folder.session(tmp_path / model_folder.MODEL_ONNX)
    assert "\n" not in str(info.value) and str(tmp_path) in str(info.value)
