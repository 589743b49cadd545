"""The seed models train through `train_command` on the generated dataset (motion a known
function of audio): each beats the mean pose; seed 004's schedule; live mode takes the causal
ones and refuses the rest in one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

import gesturebank.datasets as gds
from gesturebank.app.robot import load_frame_model
from gesturebank.cli.training import train_command
from gesturebank.config import TrainConfig
from gesturebank.datasets.torch import load_segments, split_items
from gesturebank.errors import InputError
from gesturebank.train.export import OnnxModel
from gesturebank.train.model_folder import MODEL_ONNX, load, load_model
from gesturebank.train.models.aud2repr2pose import Aud2Repr2Pose
from gesturebank.train.models.build import build_model
from gesturebank.train.torch_runtime import predict, validation_loss
from gesturebank.train.trainer import EARLY_STOP
from tests.train.test_trainer import mean_pose_val_loss

# Tiny sizes and few epochs: seconds per model; the relation is simple enough.
TINY = TrainConfig.model_validate(
    {
        "aud2motion": {"units": 16, "fc_layers": 1, "learning_rate": 0.02, "batch_size": 8,
                       "stride": 100, "max_epochs": 10, "dropout": 0.0},
        "aud2pose": {"units": 12, "fc_layers": 1, "context": 10, "learning_rate": 0.02,
                     "batch_size": 8, "stride": 100, "max_epochs": 12, "dropout": 0.0},
        "blstm": {"units": 12, "layers": 1, "receptive": 21, "span": 5, "batch_size": 8,
                  "stride": 100, "max_epochs": 10},
        "cvae": {"units": 16, "layers": 1, "batch_size": 8, "stride": 100, "max_epochs": 20},
        "rmsprop": {"learning_rate": 0.01, "min_lr": 0.0001, "patience": 2},
        "aud2repr2pose": {"dae_learning_rate": 0.01},
        "dcccae": {"ae_units": 32, "code": 8, "regressor_units": 32, "learning_rate": 0.003,
                   "batch_size": 8, "stride": 100, "max_epochs": 12},
    }
)  # fmt: skip


@pytest.mark.parametrize(
    "kind", ["aud2motion", "aud2pose", "blstm", "cvae", "aud2repr2pose", "dcccae"]
)
def test_every_seed_model_beats_the_mean_pose(
    kind: str, synthetic_dataset: Path, tmp_path: Path
) -> None:
    baseline = mean_pose_val_loss(synthetic_dataset, 0)
    out = tmp_path / kind
    result = train_command(
        synthetic_dataset,
        model=kind,
        variant="si",
        fold=0,
        subject=None,
        out_dir=out,
        config=TINY,
        quiet=True,
    )
    assert result.best_val_loss < 0.5 * baseline, (result.best_val_loss, baseline)
    folder = load(out)
    assert folder.info.architecture["kind"] == kind
    # offline synthesis's graph gives what the trained torch model gives
    model, _, _ = load_model(out)
    ds = gds.open(synthetic_dataset)
    val = load_segments(ds, split_items(ds, variant="si", part="val", fold=0))
    assert validation_loss(model, val) == pytest.approx(result.best_val_loss, rel=1e-6)
    onnx = OnnxModel(folder.file(MODEL_ONNX))
    np.testing.assert_allclose(onnx.predict(val[0].audio), predict(model, val[0].audio), atol=1e-5)
    if kind == "aud2motion":
        live = load_frame_model(out)
        assert live.model.stateful  # type: ignore[attr-defined]
    else:
        with pytest.raises(InputError, match=f"model '{kind}' is not causal") as err:
            load_frame_model(out)
        assert "\n" not in str(err.value)


def test_seed_004_schedule_visits_three_rates_then_stops(
    synthetic_dataset: Path, tmp_path: Path
) -> None:
    cfg = TrainConfig.model_validate(
        {
            "cvae": {"units": 8, "layers": 1, "batch_size": 16, "stride": 100, "max_epochs": 200},
            "rmsprop": {"patience": 1},
        }
    )  # fmt: skip  (the paper's 1e-3 → 1e-5, a short patience to be quick)
    r = train_command(
        synthetic_dataset,
        model="cvae",
        variant="si",
        fold=1,
        subject=None,
        out_dir=tmp_path / "c",
        config=cfg,
        quiet=True,
    )
    rates = [h["lr"] for h in r.history]
    visited = [rate for i, rate in enumerate(rates) if i == 0 or rate != rates[i - 1]]
    assert visited == pytest.approx([1e-3, 1e-4, 1e-5])
    assert r.epochs < 200 and r.stopped == EARLY_STOP  # stopped by the schedule, not the bound
    # the stop comes one patience after the drop to 1e-5 or the best epoch, whichever is later
    dropped = int(next(h["epoch"] for h in r.history if h["lr"] == rates[-1])) - 1
    assert r.epochs - max(dropped, r.best_epoch) == 1
    assert r.best_val_loss == min(h["val_loss"] for h in r.history)


def test_dae_noise_is_a_twentieth_of_each_dimensions_std(synthetic_dataset: Path) -> None:
    ds = gds.open(synthetic_dataset)
    train = load_segments(ds, split_items(ds, variant="si", part="train", fold=0))
    model = build_model("aud2repr2pose", 26, config=TINY)
    assert isinstance(model, Aud2Repr2Pose)
    stages = model.stages(train)
    assert next(stages) == "motion DAE" and model.stage == "dae"
    # m = [angles, velocities] over frames whose pose and predecessor's are fully known
    frames = []
    for s in train:
        g = np.where(s.mask, s.target, np.nan)
        m = np.concatenate([g[1:], g[1:] - g[:-1]], axis=1)
        frames.append(m[np.isfinite(m).all(axis=1)])
    std = np.concatenate(frames).std(axis=0)
    np.testing.assert_allclose(model.noise_std.numpy(), 0.05 * std, rtol=1e-4)
    assert (std == 0).any() and (std > 0).any()  # per dimension: still joints get no noise
    clean = torch.zeros(200_000, 22)
    noise = model.corrupt(clean).numpy()
    np.testing.assert_allclose(noise.std(axis=0), 0.05 * std, rtol=0.02, atol=1e-7)
    assert next(stages) == "speech encoder" and model.stage == "speech"


def test_cli_trains_a_seed_model_and_live_refuses_it_in_one_line(
    synthetic_dataset: Path, samples: Path, tmp_path: Path
) -> None:
    import subprocess
    import sys

    gesturebank = str(Path(sys.executable).parent / "gesturebank")
    out = tmp_path / "cvae"
    sets = ["--set", "train.cvae.units=8", "--set", "train.cvae.layers=1",
            "--set", "train.cvae.max_epochs=2", "--set", "train.cvae.stride=100"]  # fmt: skip
    r = subprocess.run(
        [gesturebank, "train", str(synthetic_dataset), "--model", "cvae", "--out", str(out),
         "--quiet", *sets],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert load(out).info.architecture["kind"] == "cvae"
    wav = next((samples / "speech").glob("*.wav"))
    r = subprocess.run(
        [gesturebank, "live", str(out), "--backend", "record", "--input", str(wav),
         "--out", str(tmp_path / "live.jsonl")],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert r.returncode == 2
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "model 'cvae' is not causal" in lines[0], r.stderr
    r = subprocess.run(
        [gesturebank, "train", str(synthetic_dataset), "--model", "gan", "--out", str(out)],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert r.returncode == 2 and "unknown model 'gan' (--model); one of: aud2motion" in r.stderr
    assert (out / "model.json").is_file()  # the earlier model is untouched


SEED_MODELS = ["aud2motion", "aud2pose", "blstm", "cvae", "aud2repr2pose", "dcccae"]


def test_every_seed_model_trains_on_real_media_and_compare_tables_them(
    real_dataset: Path, tmp_path: Path
) -> None:
    """#19's acceptance on the dataset built from the sample media: every model trains to
    completion (tiny sizes) and `compare` prints one table of them all beside the baselines.
    No quality claim: the demo's speech and motion are unrelated."""
    from rich.console import Console

    from gesturebank.app.compare import compare_command

    cfg = TINY.model_copy(update={"cvae": TINY.cvae.model_copy(update={"max_epochs": 3})})
    dirs = []
    for kind in SEED_MODELS:
        result = train_command(
            real_dataset,
            model=kind,
            variant="si",
            fold=0,
            subject=None,
            out_dir=tmp_path / kind,
            config=cfg,
            quiet=True,
        )
        assert result.epochs >= 1 and np.isfinite(result.best_val_loss), kind
        dirs.append(tmp_path / kind)
    console = Console(record=True, width=250)
    report = compare_command(dirs, console=console)
    text = console.export_text()
    assert list(report["systems"])[: len(SEED_MODELS)] == SEED_MODELS
    for kind in SEED_MODELS:
        assert kind in text and np.isfinite(report["systems"][kind]["loss_l"])
