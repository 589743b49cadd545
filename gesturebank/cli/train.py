"""The train / evaluate commands, as plain functions for the CLI to wrap (offline synthesis:
`synthesis`).

The model folder they write and read is `model_folder`'s (its docstring lists the files).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console

from gesturebank.config import TrainConfig
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.torch import Segment, load_segments, split_items
from gesturebank.errors import InputError
from gesturebank.train import model_folder
from gesturebank.train.evaluate import (
    FIELD_MEASURES,
    LEGEND,
    SEED_MEASURES,
    TABLE_5_1,
    average,
    evaluate_segments,
    footnotes,
    table,
)
from gesturebank.train.export import export_onnx
from gesturebank.train.loss_plot import write_loss_png
from gesturebank.train.model_folder import LOSS_PNG
from gesturebank.train.models import build_model
from gesturebank.train.models import predict as torch_predict
from gesturebank.train.registry import MODELS
from gesturebank.train.trainer import TrainResult, torch_settings, train

PathLike = str | os.PathLike[str]


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
    epochs: int | None = None,
) -> TrainResult:
    """Train `model` (a `train.registry.MODELS` name) on a SI fold (default 0) or a SD subject.

    `epochs` replaces the model's `max_epochs` (each stage's, for a model trained in stages);
    early stopping may still end it sooner. loss.png beside model.json draws the losses.

    The model folder is written beside `out_dir` and swapped in whole, so no file of an older
    model survives and a failed or interrupted run keeps the old one.
    """
    cfg = config or TrainConfig()
    MODELS.check(model)  # before any data is read
    if variant == "si" and fold is None:
        fold = 0
    out = Path(out_dir)
    model_folder.check_target(out)
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
    with model_folder.writing(out) as tmp:
        result = train(
            net, train_segments, val_segments, cfg, quiet=quiet, description=what, epochs=epochs
        )
        export_onnx(net, tmp)
        write_loss_png(tmp / LOSS_PNG, history=result.history, title=f"{what}: loss per epoch")
        model_folder.write(
            tmp,
            net=net,
            dataset=ds,
            variant=variant,
            fold=fold,
            subject=subject,
            config=cfg,
            result=result,
            mean_pose01=_mean_pose01(train_segments),
        )
    return result


def evaluate_command(
    model_dir: PathLike,
    dataset: PathLike | None = None,
    split: str = "test",
    *,
    console: Console | None = None,
) -> dict[str, Any]:
    """Score a model on a split part of `dataset` (default: the one it was trained on).

    Prints a Table-5.1-style table (per subject, plus the average; the model and the
    baselines), the seeds' and the field's measures (FGD with its autoencoder's version), and
    writes metrics.json into the model folder; returns its content.
    """
    from gesturebank.train.fgd import label as fgd_label
    from gesturebank.train.field import prepare

    folder = model_folder.load(model_dir)
    net, info, norm = folder.torch_model(), folder.info, folder.norm
    cfg = folder.train_config
    ds = open_dataset(dataset or info["dataset"])
    inputs = prepare(
        ds,
        variant=info["variant"],
        fold=info["fold"],
        subject=info["subject"],
        part=split,
        config=cfg,
    )
    segments = inputs.segments
    profile = folder.profile
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
        donors=inputs.donors,
        fgd=inputs.fgd,
        onsets=inputs.onsets,
    )
    fgd_version = inputs.fgd.version if inputs.fgd else None
    report = {
        "model": name,
        "split": split,
        "dataset": str(ds.path.resolve()),
        "fold": info["fold"],
        "subject": info["subject"],
        "fgd_version": fgd_version,
        "per_subject": results,
        "average": average(results),
    }
    model_folder.write_metrics(folder.path, report)
    out = console or Console()
    title = f"{name} on {split} ({ds.path.name})"
    # n/a in the tables: a mark, and why once below them, not a number
    notes = footnotes(results, {"fgd": inputs.fgd_note} if inputs.fgd_note else None)
    out.print(table(results, title, TABLE_5_1, notes))
    out.print(table(results, f"{title}: seed measures", SEED_MEASURES, notes))
    fgd_title = fgd_label(inputs.fgd)
    out.print(table(results, f"{title}: GENEA/BEAT measures ({fgd_title})", FIELD_MEASURES, notes))
    for line in [LEGEND, *notes.lines]:
        out.print(line, highlight=False, soft_wrap=True)
    return report
