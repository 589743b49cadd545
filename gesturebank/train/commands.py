"""The train / evaluate / synthesize commands, as plain functions for the CLI to wrap.

A model folder (written by `train_command`):

    weights.pt         state dict (load with torch.load(weights_only=True))
    model.json         architecture, variant and split, resolved TrainConfig, audio config,
                       frame rate, training history
    normalisers.json   audio z-norm stats per subject and "*" (dataset.json), angle limits,
                       the training mean pose (normalised) for the mean-pose baseline
    model.onnx         offline inference graph; model_step.onnx for the LSTM (stateful step)
    metrics.json       written by `evaluate_command`
"""

from __future__ import annotations

import csv
import io
import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import torch
from rich.console import Console

from gesturebank import __version__
from gesturebank.config import AudioConfig, TrainConfig
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.store import Dataset
from gesturebank.datasets.torch import Segment, load_segments, split_items
from gesturebank.errors import InputError
from gesturebank.extract.audio import apply_znorm, features
from gesturebank.fileio import atomic_folder, output_errors, write_bytes_atomic
from gesturebank.robot import pepper
from gesturebank.train.evaluate import (
    SEED_MEASURES,
    TABLE_5_1,
    average,
    evaluate_segments,
    not_computable,
    postprocess,
    table,
)
from gesturebank.train.export import MODEL_ONNX, OnnxModel, export_onnx
from gesturebank.train.models import MLP, LSTMModel, architecture, build_model, from_architecture
from gesturebank.train.models import predict as torch_predict
from gesturebank.train.trainer import TrainResult, torch_settings, train

WEIGHTS = "weights.pt"
MODEL_JSON = "model.json"
NORMALISERS = "normalisers.json"
METRICS = "metrics.json"

PathLike = str | os.PathLike[str]


def _write_json(path: Path, data: Any) -> None:
    write_bytes_atomic(path, json.dumps(data, indent=1, allow_nan=True).encode())


def _profile(limits: dict[str, dict[str, float]], name: str) -> pepper.RobotProfile:
    table_ = np.array(
        [[limits[j][k] for k in ("lower", "upper", "velocity")] for j in pepper.JOINTS]
    )
    return pepper.RobotProfile(name, "from the dataset", table_[:, 0], table_[:, 1], table_[:, 2])


def _mean_pose01(segments: list[Segment]) -> np.ndarray:
    """(11,) mean of the known training targets per joint (0.5 for a joint never known)."""
    target = np.concatenate([s.target for s in segments])
    mask = np.concatenate([s.mask for s in segments])
    count = mask.sum(axis=0)
    return np.where(count > 0, (target * mask).sum(axis=0) / np.maximum(count, 1), 0.5)


def train_command(
    dataset: PathLike,
    model: str,
    variant: str,
    fold: int | None = None,
    subject: str | None = None,
    out_dir: PathLike = "model",
    config: TrainConfig | None = None,
    *,
    quiet: bool = False,
) -> TrainResult:
    """Train `model` ('mlp' | 'lstm') on a SI fold (default 0) or a SD subject.

    The model folder is written beside `out_dir` and swapped in whole, so no file of an older
    model survives and a failed or interrupted run keeps the old one.
    """
    cfg = config or TrainConfig()
    if variant == "si" and fold is None:
        fold = 0
    out = Path(out_dir)
    _check_model_folder(out)
    ds = open_dataset(dataset)
    train_segments = load_segments(
        ds, split_items(ds, variant, "train", fold=fold, subject=subject)
    )
    val_segments = load_segments(ds, split_items(ds, variant, "val", fold=fold, subject=subject))
    if not train_segments or not val_segments:
        raise InputError(f"{ds.path}: the {variant} split has an empty train or val part")
    n_features = train_segments[0].audio.shape[1]
    with torch_settings(cfg.seed, cfg.threads):
        net = build_model(model, n_features, cfg)
    part = f"fold {fold}" if variant == "si" else f"subject {subject}"
    what = f"{model.upper()}-{variant.upper()} {part}"
    # the temporary folder is made before training, so an unwritable --out fails at once
    with output_errors(out, "the model folder"), atomic_folder(out) as tmp:
        result = train(net, train_segments, val_segments, cfg, quiet=quiet, description=what)
        _write_model(
            tmp,
            net=net,
            ds=ds,
            variant=variant,
            fold=fold,
            subject=subject,
            cfg=cfg,
            result=result,
            train_segments=train_segments,
        )
    return result


def _check_model_folder(out: Path) -> None:
    """Refuse an --out that training would wipe although it holds something else."""
    if out.exists() and (
        not out.is_dir() or (any(out.iterdir()) and not (out / MODEL_JSON).is_file())
    ):
        raise InputError(f"{out}: exists and is not a model folder (no {MODEL_JSON}); choose --out")


def _write_model(
    out: Path,
    *,
    net: MLP | LSTMModel,
    ds: Dataset,
    variant: str,
    fold: int | None,
    subject: str | None,
    cfg: TrainConfig,
    result: TrainResult,
    train_segments: list[Segment],
) -> None:
    torch.save(net.state_dict(), out / WEIGHTS)
    export_onnx(net, out)
    _write_json(
        out / MODEL_JSON,
        {
            "tool_version": __version__,
            "architecture": architecture(net),
            "variant": variant,
            "fold": fold,
            "subject": subject,
            "dataset": str(ds.path.resolve()),
            "train_config": cfg.model_dump(mode="json"),
            "audio": ds.info.config.audio.model_dump(mode="json"),
            "rate_hz": ds.info.rates.pose_hz,
            "result": {
                "best_epoch": result.best_epoch,
                "best_val_loss": result.best_val_loss,
                "epochs": result.epochs,
                "seconds": result.seconds,
                "history": result.history,
            },
        },
    )
    _write_json(
        out / NORMALISERS,
        {
            "audio_znorm_by_subject": {
                k: v.model_dump() for k, v in ds.info.audio_znorm_by_subject.items()
            },
            "limits": ds.info.limits,
            "robot_profile": ds.info.robot_profile,
            "joints": list(pepper.JOINTS),
            "mean_pose01": _mean_pose01(train_segments).tolist(),
        },
    )


def load_model(model_dir: PathLike) -> tuple[MLP | LSTMModel, dict[str, Any], dict[str, Any]]:
    """(torch model with its trained weights, model.json, normalisers.json) of a model folder."""
    folder = Path(model_dir)
    try:
        info = json.loads((folder / MODEL_JSON).read_text())
        norm = json.loads((folder / NORMALISERS).read_text())
    except FileNotFoundError as exc:
        raise InputError(f"{folder}: not a trained model folder ({exc.filename} missing)") from None
    net = from_architecture(info["architecture"])
    net.load_state_dict(torch.load(folder / WEIGHTS, weights_only=True))
    net.eval()
    return net, info, norm


def evaluate_command(
    model_dir: PathLike,
    dataset: PathLike | None = None,
    split: str = "test",
    *,
    console: Console | None = None,
) -> dict[str, Any]:
    """Score a model on a split part of `dataset` (default: the one it was trained on).

    Prints a Table-5.1-style table (per subject, plus the average; the model and both baselines)
    and writes metrics.json into the model folder; returns its content.
    """
    net, info, norm = load_model(model_dir)
    cfg = TrainConfig.model_validate(info["train_config"])
    ds = open_dataset(dataset or info["dataset"])
    items = split_items(ds, info["variant"], split, fold=info["fold"], subject=info["subject"])
    segments = load_segments(ds, items)
    if not segments:
        raise InputError(f"{ds.path}: the {split} part of this split is empty")
    profile = _profile(norm["limits"], norm["robot_profile"])
    with torch_settings(cfg.seed, cfg.threads):
        pred01 = [torch_predict(net, s.audio) for s in segments]
    name = f"{info['architecture']['kind'].upper()}-{info['variant'].upper()}"
    results = evaluate_segments(
        segments,
        pred01,
        name=name,
        mean_pose01=np.asarray(norm["mean_pose01"]),
        profile=profile,
        rate_hz=float(info["rate_hz"]),
        config=cfg,
    )
    report = {
        "model": name,
        "split": split,
        "dataset": str(ds.path.resolve()),
        "fold": info["fold"],
        "subject": info["subject"],
        "per_subject": results,
        "average": average(results),
    }
    with output_errors(Path(model_dir) / METRICS, "the metrics"):
        _write_json(Path(model_dir) / METRICS, report)
    out = console or Console()
    title = f"{name} on {split} ({ds.path.name})"
    out.print(table(results, title, TABLE_5_1))
    out.print(table(results, f"{title}: seed measures", SEED_MEASURES))
    for line in not_computable(results):  # n/a in the tables: say why, not a number
        out.print(f"note: {line}", highlight=False, soft_wrap=True)
    return report


def synthesize_command(
    model_dir: PathLike,
    audio_path: PathLike,
    out_csv: PathLike,
    *,
    znorm: str = "*",
) -> np.ndarray:
    """Offline synthesis (§4.4.1): audio file → angles `(N, 11)` rad, also written as CSV.

    Features with the training audio config → z-norm (`znorm`: "*" = whole-dataset stats, as the
    dissertation's synthesis; a subject name = that subject's; "self" = the file's own) → ONNX
    model → ν⁻¹ → Butterworth post-smoothing → clamp. CSV columns: time_s (centre of each
    feature window, seconds from the first sample) and the 11 joint names.
    """
    from gesturebank.extract.video import read_audio

    folder = Path(model_dir)
    _, info, norm = load_model(folder)
    cfg = TrainConfig.model_validate(info["train_config"])
    audio_cfg = AudioConfig.model_validate(info["audio"])
    track = read_audio(audio_path, audio_cfg.sample_rate)
    if track is None:
        raise InputError(f"{audio_path}: no audio track")
    feats = features(track.signal, track.sample_rate, audio_cfg)
    if znorm == "self":
        mean, std = feats.mean(axis=0), feats.std(axis=0)
    else:
        stats = norm["audio_znorm_by_subject"]
        if znorm not in stats:
            raise InputError(f"no audio normalisation {znorm!r}; known: {', '.join(sorted(stats))}")
        mean, std = np.asarray(stats[znorm]["mean"]), np.asarray(stats[znorm]["std"])
    pred01 = OnnxModel(folder / MODEL_ONNX).predict(apply_znorm(feats, mean, std))
    profile = _profile(norm["limits"], norm["robot_profile"])
    angles = postprocess(pred01, profile, float(info["rate_hz"]), cfg)
    times = np.arange(len(angles)) * audio_cfg.winstep_s + audio_cfg.winlen_s / 2
    text = io.StringIO(newline="")
    writer = csv.writer(text)
    writer.writerow(["time_s", *pepper.JOINTS])
    for t, row in zip(times, angles, strict=True):
        writer.writerow([f"{t:.4f}", *(f"{v:.6f}" for v in row)])
    with output_errors(out_csv, "the angle CSV"):
        write_bytes_atomic(out_csv, text.getvalue().encode("utf-8"))
    return angles
