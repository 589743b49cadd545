"""Seed 004's listener target: `train --target listener` learns a listener's head from the
partner's speech and speaking flag, with the loss on listening frames only; models record their
target; `evaluate` reports per role."""

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import gesturebank.datasets
from gesturebank.cli import app
from gesturebank.cli.training import evaluate_command, train_command
from gesturebank.config import TrainConfig
from gesturebank.datasets.partners import LISTENING, SPEAKING
from gesturebank.datasets.torch import load_segments, split_items
from gesturebank.errors import InputError
from gesturebank.robot import pepper
from gesturebank.testing.clips import synthetic_clip, write_dataset

HEAD = [pepper.INDEX["HeadPitch"], pepper.INDEX["HeadYaw"]]
QUICK = {
    "mlp": {"max_epochs": 3},
    "blstm": {"max_epochs": 1, "layers": 1, "units": 8, "receptive": 9, "span": 3},
    "eval": {"fgd_epochs": 2},
}


def test_listener_segments_see_the_partners_flag_and_know_only_the_listening_head(
    dyad_dataset: Path,
) -> None:
    ds = gesturebank.datasets.open(dyad_dataset)
    items = split_items(ds, variant="dyadic", part="train")
    speaker_view = load_segments(ds, items)
    listener_view = load_segments(ds, items, target="listener")
    assert len(listener_view) == len(speaker_view) == len(items)  # everyone listens in turn
    for s, heard in zip(speaker_view, listener_view, strict=True):
        arrays = ds.load_arrays(heard.clip_id)
        assert heard.audio.shape == (len(s), s.audio.shape[1] + 1)
        np.testing.assert_array_equal(heard.audio[:, :-1], s.audio)
        flag = arrays["partner_speaking"].astype(np.float32)
        np.testing.assert_array_equal(heard.audio[:, -1], flag)
        listening = arrays["role"] == LISTENING
        # the loss is on listening frames only
        assert heard.mask[:, HEAD].any() and not heard.mask[~listening].any()
        assert not np.delete(heard.mask, HEAD, axis=1).any()  # and on the head only
        np.testing.assert_array_equal(heard.mask[listening][:, HEAD], s.mask[listening][:, HEAD])
        # the partner speaks exactly while this person listens (turn-taking)
        np.testing.assert_array_equal(arrays["partner_speaking"], listening)


def test_a_listener_model_trains_records_its_target_and_is_scored_per_role(
    dyad_dataset: Path, tmp_path: Path
) -> None:
    """Issue 32's acceptance: `train --model blstm --target listener` trains and evaluates."""
    cfg = TrainConfig.model_validate({**QUICK, "target": "listener"})
    out = tmp_path / "listener"
    train_command(
        dyad_dataset, model="blstm", variant="dyadic", out_dir=out, config=cfg, quiet=True
    )
    info = json.loads((out / "model.json").read_text())
    assert info["target"] == "listener" and info["variant"] == "dyadic"
    assert info["architecture"]["n_features"] == 27  # 26 features + the speaking flag
    report = evaluate_command(out)
    roles = report["per_role"]
    assert report["target"] == "listener"
    assert roles["listening"]["known"] > 0 and np.isfinite(roles["listening"]["L"])
    assert roles["speaking"]["frames"] > 0 and roles["speaking"]["known"] == 0  # not its job
    assert np.isnan(roles["speaking"]["L"])


def test_a_speaker_model_is_scored_on_speaking_and_listening_frames(
    dyad_dataset: Path, tmp_path: Path
) -> None:
    out = tmp_path / "speaker"
    train_command(
        dyad_dataset,
        model="mlp",
        variant="dyadic",
        out_dir=out,
        config=TrainConfig.model_validate(QUICK),
    )
    assert json.loads((out / "model.json").read_text())["target"] == "speaker"
    roles = evaluate_command(out)["per_role"]
    test = gesturebank.datasets.open(dyad_dataset)
    ids = split_items(test, variant="dyadic", part="test")
    role = np.concatenate([test.load_arrays(c)["role"] for c, _, _ in ids])
    assert roles["speaking"]["frames"] == np.sum(role == SPEAKING)
    assert roles["listening"]["frames"] == np.sum(role == LISTENING)
    assert roles["speaking"]["known"] > 0 and roles["listening"]["known"] > 0
    assert roles["unknown"]["frames"] == 0


def test_the_listener_target_needs_partners(tmp_path: Path) -> None:
    lone = write_dataset(tmp_path / "lone", {"s1_a": [synthetic_clip(clip_id="s1_a__c000")]})
    cfg = TrainConfig(target="listener")
    with pytest.raises(InputError, match='no listener example.*build.people = "all"'):
        train_command(
            lone, model="mlp", variant="sd", subject="s1", out_dir=tmp_path / "m", config=cfg
        )
    with pytest.raises(InputError, match="no dyadic split: no clip has a partner"):
        train_command(lone, model="mlp", variant="dyadic", out_dir=tmp_path / "m", config=cfg)


def test_train_help_names_the_targets_and_the_dyadic_split() -> None:
    result = CliRunner().invoke(app, ["train", "--help"], terminal_width=200)
    assert result.exit_code == 0
    text = " ".join(result.output.replace("│", " ").split())
    assert "--target <speaker|listener>" in text
    assert "--variant <si|sd|dyadic>" in text
