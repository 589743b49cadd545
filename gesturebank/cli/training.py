"""The work of `gesturebank train` and `evaluate` as plain functions (`train_command`,
`evaluate_command`, `evaluate_timelines_command`), apart from the commands' options
(`cli.train`) so that torch is imported only by a command that trains or scores.

The model folder they write and read is `train.model_folder`'s (its docstring lists the files).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console

from gesturebank.app import NARROW_COLUMNS
from gesturebank.app.eval_table import table
from gesturebank.app.train_progress import EpochBar
from gesturebank.config import TrainConfig
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.store import Dataset
from gesturebank.datasets.torch import Segment, choose_variant, load_segments, split_items
from gesturebank.errors import InputError
from gesturebank.robot import pepper
from gesturebank.train import model_folder
from gesturebank.train.eval.compare import model_names
from gesturebank.train.eval.evaluate import (
    FIELD_MEASURES,
    LEGEND,
    SEED_MEASURES,
    TABLE_5_1,
    average,
    baselines,
    postprocess,
    score_systems,
)
from gesturebank.train.eval.field import SplitInputs
from gesturebank.train.eval.roles import per_role
from gesturebank.train.eval.tables import (
    WORSE_LEGEND,
    footnotes,
    units,
    worse_lines,
    worse_than_mean_pose,
)
from gesturebank.train.eval.timelines import system_angles
from gesturebank.train.export import export_onnx
from gesturebank.train.loss_plot import write_loss_png
from gesturebank.train.model_folder import LOSS_PNG
from gesturebank.train.models.build import build_model
from gesturebank.train.parts import default_require, target_joints
from gesturebank.train.registry import MODELS
from gesturebank.train.torch_runtime import predict as torch_predict
from gesturebank.train.torch_runtime import torch_settings
from gesturebank.train.trainer import TrainResult, train

PathLike = str | os.PathLike[str]
log = logging.getLogger(__name__)


def data_warnings(
    model: str,
    *,
    config: TrainConfig,
    parts: dict[str, list[Segment]],
    rate_hz: float,
) -> list[str]:
    """Why a model trained on these parts will likely be useless: a train part under
    `config.min_train_s`, or a part whose every stretch is shorter than the model's training
    window (its `seq_len`: the windows are then mostly padding)."""
    found = []
    seconds = {p: sum(len(s) for s in segs) / rate_hz for p, segs in parts.items()}
    if seconds["train"] < config.min_train_s:
        found.append(
            f"the train part holds {seconds['train']:.1f} s, under train.min_train_s "
            f"({config.min_train_s:g} s): a model learns little from so little (`evaluate` "
            "says whether it beats the mean pose)"
        )
    seq_len = getattr(getattr(config, model, None), "seq_len", None)
    for part, segs in parts.items():
        longest = max((len(s) for s in segs), default=0)
        if seq_len is not None and longest < seq_len:
            found.append(
                f"the {part} part's longest stretch is {longest / rate_hz:.2f} s, shorter than "
                f"{model}'s {seq_len / rate_hz:g} s training window (train.{model}.seq_len = "
                f"{seq_len} frames): its windows are mostly padding"
            )
    return found


def _mean_pose01(segments: list[Segment]) -> np.ndarray:
    """(11,) mean of the known training targets per joint (0.5 for a joint never known)."""
    target = np.concatenate([s.target for s in segments])
    mask = np.concatenate([s.mask for s in segments])
    count = mask.sum(axis=0)
    return np.where(count > 0, (target * mask).sum(axis=0) / np.maximum(count, 1), 0.5)


def train_command(
    dataset: PathLike,
    *,
    model: str,
    variant: str | None,
    fold: int | None = None,
    subject: str | None = None,
    out_dir: PathLike = "model",
    config: TrainConfig | None = None,
    quiet: bool = False,
    epochs: int | None = None,
    require: str | None = None,
    on_warning: Callable[[str], None] | None = None,
) -> TrainResult:
    """Train `model` (a `train.registry.MODELS` name) on a SI fold (default 0) or a SD subject;
    `variant` None: the one the dataset supports (`datasets.torch.choose_variant`, its note
    given to `on_warning`).

    `epochs` replaces the model's `max_epochs` (each stage's, for a model trained in stages);
    early stopping may still end it sooner. loss.png beside model.json draws the losses.
    `require`: body parts every clip trained on must have ("head", "arms", ...); None: what the
    model's targets need (`train.parts.default_require`). `on_warning` gets each of
    `data_warnings` before training (default: logged).

    The model folder is written beside `out_dir` and swapped in whole, so no file of an older
    model survives and a failed or interrupted run keeps the old one.
    """
    cfg = config or TrainConfig()
    MODELS.check(model)  # before any data is read
    out = Path(out_dir)
    model_folder.check_target(out)
    # a listener model predicts the head only (seed 004), whatever the model class predicts
    targets = pepper.HEAD_JOINTS if cfg.target == "listener" else target_joints(MODELS.get(model))
    need = require if require is not None else default_require(targets)
    ds = open_dataset(dataset, require=need)
    variant, subject, chose = choose_variant(ds, variant=variant, fold=fold, subject=subject)
    if chose:
        (on_warning or log.warning)(chose)
    if variant == "si" and fold is None:
        fold = 0
    train_segments, val_segments = (
        load_segments(
            ds,
            split_items(ds, variant=variant, part=p, fold=fold, subject=subject),
            target=cfg.target,
        )
        for p in ("train", "val")
    )
    if cfg.target == "listener" and not (train_segments and val_segments):
        raise InputError(
            f"{ds.path}: the {variant} split has no listener example in its train or val part "
            "(a clip with a partner and listening frames): build the dataset with "
            'build.people = "all" from footage of two people talking'
        )
    if not train_segments or not val_segments:
        raise InputError(f"{ds.path}: the {variant} split has an empty train or val part")
    n_features = train_segments[0].audio.shape[1]
    with torch_settings(cfg.seed, cfg.threads):
        net = build_model(model, n_features, config=cfg)
    part = {"si": f"fold {fold}", "sd": f"subject {subject}"}.get(variant, "split")
    what = f"{model.upper()}-{variant.upper()} {part}" + (
        " (listener)" if cfg.target == "listener" else ""
    )
    # the temporary folder is made before training, so an unwritable --out fails at once
    with model_folder.writing(out) as tmp:
        parts = {"train": train_segments, "val": val_segments}  # once --out is known writable
        for warning in data_warnings(
            model, config=cfg, parts=parts, rate_hz=float(ds.info.rates.pose_hz)
        ):
            (on_warning or log.warning)(warning)
        bar = None if quiet else EpochBar()
        result = train(
            net,
            train_segments,
            val_segments=val_segments,
            config=cfg,
            progress=bar,
            description=what,
            epochs=epochs,
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
    *,
    dataset: PathLike | None = None,
    split: str = "test",
    timelines: Sequence[PathLike] = (),
    console: Console | None = None,
) -> dict[str, Any]:
    """Score a model on a split part of `dataset` (default: the one it was trained on), and
    beside it the angle timelines of other systems (`timelines`: folders of one file per clip,
    `train.eval.timelines`).

    Prints a Table-5.1-style table (per subject, plus the average; the model and the
    baselines), the seeds' and the field's measures (FGD with its autoencoder's version), and
    writes metrics.json into the model folder; returns its content.
    """
    from gesturebank.train.eval.field import prepare_trained

    folder = model_folder.load(model_dir)
    net, info, norm = folder.torch_model(), folder.info, folder.norm
    cfg = folder.train_config
    ds, inputs = prepare_trained(folder, dataset, part=split, config=cfg)
    variant: str = info.need(folder.path, "variant")
    segments = inputs.segments
    with torch_settings(cfg.seed, cfg.threads):
        pred01 = [torch_predict(net, s.audio) for s in segments]
    name = f"{info.need(folder.path, 'architecture')['kind'].upper()}-{variant.upper()}"
    rate_hz = float(info.need(folder.path, "rate_hz"))
    systems = {name: [postprocess(p, folder.profile, rate_hz=rate_hz, config=cfg) for p in pred01]}
    systems |= _timeline_systems(timelines, segments, ds)
    results = score_systems(
        segments,
        systems | _baselines(inputs, np.asarray(norm["mean_pose01"]), folder.profile, rate_hz, cfg),
        profile=folder.profile,
        rate_hz=rate_hz,
        config=cfg,
        fgd=inputs.fgd,
        onsets=inputs.onsets,
    )
    roles = per_role(segments, pred01=pred01, angles=systems[name])
    report = {
        "model": name,
        "split": split,
        "dataset": str(ds.path.resolve()),
        "fold": info.fold,
        "subject": info.subject,
        "fgd_version": inputs.fgd.version if inputs.fgd else None,
        "target": info.target,
        "per_subject": results,
        "average": average(results),
        "per_role": roles,
    }
    model_folder.write_metrics(folder.path, report)
    title = f"{name} on {split} ({ds.path.name})"
    if info.target != "speaker":
        title = f"{name} ({info.target}) on {split} ({ds.path.name})"
    _print_tables(results, title, inputs, console or Console())
    _print_roles(roles, f"{title}: per role", console or Console())
    _print_verdict(results, console or Console())
    return report


def _print_verdict(results: dict[str, dict[str, dict[str, Any]]], out: Console) -> None:
    """The last lines: each scored system worse than the mean pose, said plainly."""
    for line in worse_lines(results):
        out.print(f"[bold red]warning:[/bold red] {line}", highlight=False)


def _print_roles(scores: dict[str, dict[str, float]], title: str, out: Console) -> None:
    """The model's L and RMSE on the frames of each role (`train.eval.roles`)."""
    from rich.table import Table

    grid = Table(title=title, title_justify="left")
    for column in ("role", "frames", "known entries", "L", "RMSE (rad)"):
        grid.add_column(column, justify="left" if column == "role" else "right")
    for role, s in scores.items():
        grid.add_row(
            role, f"{s['frames']:.0f}", f"{s['known']:.0f}", f"{s['L']:.4f}", f"{s['rmse_rad']:.4f}"
        )
    out.print(grid)


def evaluate_timelines_command(
    timelines: Sequence[PathLike],
    *,
    dataset: PathLike,
    split: str = "test",
    variant: str = "si",
    fold: int | None = None,
    subject: str | None = None,
    config: TrainConfig | None = None,
    console: Console | None = None,
    require: str | None = None,
) -> dict[str, Any]:
    """Score the angle timelines other systems produced (`timelines`: folders of one file per
    clip of the split part, named by clip id) on a split of `dataset` (SI `fold`, default 0, or
    SD `subject`), beside the baselines, with the measures and tables of `evaluate_command`
    (the mean-pose baseline is the train part's). Returns what evaluate_command returns,
    "model" None; nothing is written."""
    from gesturebank.train.eval.field import prepare

    if not timelines:
        raise InputError("evaluate needs a model folder or --timelines")
    if variant == "si" and fold is None:
        fold = 0
    cfg = config or TrainConfig()
    ds = open_dataset(dataset, require=require)  # clips with the body parts required
    inputs = prepare(ds, variant=variant, fold=fold, subject=subject, part=split, config=cfg)
    systems = _timeline_systems(timelines, inputs.segments, ds)
    train_part = load_segments(
        ds,
        split_items(ds, variant=variant, part="train", fold=fold, subject=subject),
        target=cfg.target,
    )
    if not train_part:
        raise InputError(f"{ds.path}: the train part of this split is empty (no mean pose)")
    profile = pepper.load_profile(ds.info.robot_profile)
    rate_hz = float(ds.info.rates.pose_hz)
    results = score_systems(
        inputs.segments,
        systems | _baselines(inputs, _mean_pose01(train_part), profile, rate_hz, cfg),
        profile=profile,
        rate_hz=rate_hz,
        config=cfg,
        fgd=inputs.fgd,
        onsets=inputs.onsets,
    )
    part = {"si": f"fold {fold}", "sd": f"subject {subject}"}.get(variant, "split")
    title = f"{', '.join(systems)} on {variant.upper()} {part}, {split} ({ds.path.name})"
    _print_tables(results, title, inputs, console or Console())
    _print_verdict(results, console or Console())
    return {
        "model": None,
        "split": split,
        "dataset": str(ds.path.resolve()),
        "fold": fold,
        "subject": subject,
        "fgd_version": inputs.fgd.version if inputs.fgd else None,
        "per_subject": results,
        "average": average(results),
    }


def _timeline_systems(
    timelines: Sequence[PathLike], segments: list[Segment], dataset: Dataset
) -> dict[str, list[np.ndarray]]:
    """{folder name → angles per segment} of each timeline folder."""
    dirs = [Path(t) for t in timelines]
    return {
        name: system_angles(d, segments, dataset=dataset)
        for name, d in zip(model_names(dirs), dirs, strict=True)
    }


def _baselines(
    inputs: SplitInputs,
    mean_pose01: np.ndarray,
    profile: pepper.RobotProfile,
    rate_hz: float,
    cfg: TrainConfig,
) -> dict[str, list[np.ndarray]]:
    return baselines(
        inputs.segments,
        mean_pose01=mean_pose01,
        profile=profile,
        rate_hz=rate_hz,
        config=cfg,
        donors=inputs.donors,
    )


def _print_tables(
    results: dict[str, dict[str, dict[str, Any]]], title: str, inputs: SplitInputs, out: Console
) -> None:
    """The three tables of `evaluate`, the legend and the n/a reasons (each once)."""
    from gesturebank.train.eval.fgd import label as fgd_label

    notes = footnotes(results, {"fgd": inputs.fgd_note} if inputs.fgd_note else None)
    narrow = out.width < NARROW_COLUMNS  # short headers, units in a line of their own
    out.print(table(results, title=title, columns=TABLE_5_1, notes=notes, narrow=narrow))
    out.print(
        table(
            results,
            title=f"{title}: seed measures",
            columns=SEED_MEASURES,
            notes=notes,
            narrow=narrow,
        )
    )
    fgd_title = fgd_label(inputs.fgd)
    field_title = f"{title}: GENEA/BEAT measures ({fgd_title})"
    out.print(table(results, title=field_title, columns=FIELD_MEASURES, notes=notes, narrow=narrow))
    legend = [LEGEND, units((*TABLE_5_1, *SEED_MEASURES, *FIELD_MEASURES))] if narrow else [LEGEND]
    legend += [WORSE_LEGEND] if worse_than_mean_pose(results) else []
    for line in [*legend, *notes.lines]:  # narrow: wrapped at words, each note whole
        out.print(line, highlight=False, soft_wrap=not narrow)
