"""What a training run shows: --epochs, a line per epoch in a log, why it stopped, loss.png."""

from __future__ import annotations

import json
import re
from pathlib import Path

import cv2
import numpy as np
from typer.testing import CliRunner

from gesturebank.cli import app
from gesturebank.train.loss_plot import SIZE_PX

EPOCH_LINE = re.compile(r"^MLP-SI fold 0: epoch (\d+)/2  train [\d.]+  val [\d.]+", re.M)


def test_epochs_flag_writes_loss_png_and_a_line_per_epoch(
    synthetic_dataset: Path, tmp_path: Path
) -> None:
    out = tmp_path / "model"
    # a huge patience: only the epoch limit can end this run
    args = ["train", str(synthetic_dataset), "--epochs", "2", "--out", str(out)]
    r = CliRunner().invoke(app, [*args, "--set", "train.patience=1000"])
    assert r.exit_code == 0, r.output
    assert "\r" not in r.output  # not a terminal: plain lines, no progress bar redraws
    assert [int(n) for n in EPOCH_LINE.findall(r.output)] == [1, 2]
    assert "stopped: max epochs reached (2)" in r.output
    result = json.loads((out / "model.json").read_text())["result"]
    assert result["epochs"] == 2 and result["stopped"] == "max epochs reached"

    png = (out / "loss.png").read_bytes()
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
    assert image.shape[1::-1] == SIZE_PX
    # drawn, not blank: both curves' colours are there (matplotlib's tab:blue and tab:orange)
    bgr = image.reshape(-1, 3).astype(int)
    for colour in ((180, 119, 31), (14, 127, 255)):
        assert (np.abs(bgr - colour).sum(axis=1) < 30).sum() > 50, colour


def test_early_stopping_is_reported_as_such(synthetic_dataset: Path, tmp_path: Path) -> None:
    out = tmp_path / "model"
    sets = ["--set", "train.patience=1", "--set", "train.learning_rate=5.0"]
    r = CliRunner().invoke(
        app, ["train", str(synthetic_dataset), "--epochs", "200", "--out", str(out), *sets]
    )
    assert r.exit_code == 0, r.output
    assert "stopped: early stopping" in r.output
    result = json.loads((out / "model.json").read_text())["result"]
    assert result["stopped"] == "early stopping" and result["epochs"] < 200


def test_epochs_is_in_the_help() -> None:
    r = CliRunner().invoke(app, ["train", "--help"], env={"COLUMNS": "200"})
    assert "--epochs" in r.output and "max_epochs" in r.output


def test_a_misspelt_set_key_names_the_nearest_one(synthetic_dataset: Path) -> None:
    r = CliRunner().invoke(app, ["train", str(synthetic_dataset), "--set", "train.lstm.epochs=3"])
    assert r.exit_code == 2
    assert "train.lstm.epochs: unknown key (did you mean max_epochs?)" in r.output
