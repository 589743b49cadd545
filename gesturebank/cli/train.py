"""`gesturebank train`, `evaluate`, `compare` and `synthesize`; the training and the scoring as
plain functions (`train_command`, `evaluate_command`; the comparison is `train.compare`'s, offline
synthesis `train.synthesis`'s).

The model folder they write and read is `train.model_folder`'s (its docstring lists the files).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.console import Console

from gesturebank.cli.options import (
    ConfigOption,
    DatasetArg,
    ModelDirArg,
    QuietOption,
    SetOption,
    SplitPart,
    one_of,
    resolve_config,
)
from gesturebank.cli.terminal import out, user_errors
from gesturebank.config import TrainConfig, Variant
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.store import Dataset
from gesturebank.datasets.torch import Segment, load_segments, split_items
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
    footnotes,
    postprocess,
    score_systems,
    table,
)
from gesturebank.train.eval.field import SplitInputs
from gesturebank.train.eval.timelines import system_angles
from gesturebank.train.export import export_onnx
from gesturebank.train.loss_plot import write_loss_png
from gesturebank.train.model_folder import LOSS_PNG
from gesturebank.train.models.build import build_model
from gesturebank.train.registry import MODELS
from gesturebank.train.torch_runtime import predict as torch_predict
from gesturebank.train.torch_runtime import torch_settings
from gesturebank.train.trainer import TrainResult, train

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
    from gesturebank.train.eval.field import prepare

    folder = model_folder.load(model_dir)
    net, info, norm = folder.torch_model(), folder.info, folder.norm
    cfg = folder.train_config
    ds = open_dataset(dataset or info.need(folder.path, "dataset"))
    variant: str = info.need(folder.path, "variant")
    inputs = prepare(
        ds,
        variant=variant,
        fold=info.fold,
        subject=info.subject,
        part=split,
        config=cfg,
    )
    segments = inputs.segments
    with torch_settings(cfg.seed, cfg.threads):
        pred01 = [torch_predict(net, s.audio) for s in segments]
    name = f"{info.need(folder.path, 'architecture')['kind'].upper()}-{variant.upper()}"
    rate_hz = float(info.need(folder.path, "rate_hz"))
    systems = {name: [postprocess(p, folder.profile, rate_hz, cfg) for p in pred01]}
    systems |= _timeline_systems(timelines, segments, ds)
    results = score_systems(
        segments,
        systems | _baselines(inputs, np.asarray(norm["mean_pose01"]), folder.profile, rate_hz, cfg),
        folder.profile,
        rate_hz,
        cfg,
        fgd=inputs.fgd,
        onsets=inputs.onsets,
    )
    report = {
        "model": name,
        "split": split,
        "dataset": str(ds.path.resolve()),
        "fold": info.fold,
        "subject": info.subject,
        "fgd_version": inputs.fgd.version if inputs.fgd else None,
        "per_subject": results,
        "average": average(results),
    }
    model_folder.write_metrics(folder.path, report)
    _print_tables(results, f"{name} on {split} ({ds.path.name})", inputs, console or Console())
    return report


def evaluate_timelines_command(
    timelines: Sequence[PathLike],
    dataset: PathLike,
    split: str = "test",
    *,
    variant: str = "si",
    fold: int | None = None,
    subject: str | None = None,
    config: TrainConfig | None = None,
    console: Console | None = None,
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
    ds = open_dataset(dataset)
    inputs = prepare(ds, variant=variant, fold=fold, subject=subject, part=split, config=cfg)
    systems = _timeline_systems(timelines, inputs.segments, ds)
    train_part = load_segments(ds, split_items(ds, variant, "train", fold=fold, subject=subject))
    if not train_part:
        raise InputError(f"{ds.path}: the train part of this split is empty (no mean pose)")
    profile = pepper.load_profile(ds.info.robot_profile)
    rate_hz = float(ds.info.rates.pose_hz)
    results = score_systems(
        inputs.segments,
        systems | _baselines(inputs, _mean_pose01(train_part), profile, rate_hz, cfg),
        profile,
        rate_hz,
        cfg,
        fgd=inputs.fgd,
        onsets=inputs.onsets,
    )
    part = f"fold {fold}" if variant == "si" else f"subject {subject}"
    title = f"{', '.join(systems)} on {variant.upper()} {part}, {split} ({ds.path.name})"
    _print_tables(results, title, inputs, console or Console())
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
    out.print(table(results, title, TABLE_5_1, notes))
    out.print(table(results, f"{title}: seed measures", SEED_MEASURES, notes))
    fgd_title = fgd_label(inputs.fgd)
    out.print(table(results, f"{title}: GENEA/BEAT measures ({fgd_title})", FIELD_MEASURES, notes))
    for line in [LEGEND, *notes.lines]:
        out.print(line, highlight=False, soft_wrap=True)


def train_cmd(
    dataset: DatasetArg,
    model: Annotated[str, typer.Option(help=f"The network, {one_of(MODELS)}.")] = "mlp",
    variant: Annotated[
        Variant, typer.Option(help="'si' subject-independent (a fold) or 'sd' (one subject).")
    ] = "si",
    fold: Annotated[int | None, typer.Option(help="SI fold (default 0).")] = None,
    subject: Annotated[str | None, typer.Option(help="SD subject.")] = None,
    out_dir: Annotated[
        Path, typer.Option("--out", help="Model folder to write (an older one is replaced whole).")
    ] = Path("model"),
    epochs: Annotated[
        int | None,
        typer.Option(
            min=1,
            help="Most epochs to train (replaces the model's [train.MODEL] max_epochs); early "
            "stopping may end sooner.",
        ),
    ] = None,
    config_file: ConfigOption = None,
    sets: SetOption = None,
    quiet: QuietOption = False,
) -> None:
    """Train a speech-to-motion model on a dataset split: the dissertation's MLP or LSTM (§4.3)
    or a seed model — aud2motion (causal GRU), aud2pose (BiGRU window), aud2repr2pose (motion
    autoencoder, then speech to its code), blstm (span predictor), cvae (sampled motion), dcccae
    (CCA-coupled autoencoders) — each with its paper's optimiser and schedule ([train.NAME]).

    Training stops early when the validation loss stops falling (train.patience), else at the
    epoch limit; the last line says which. On a terminal a progress bar shows the losses; in a
    log, one line per epoch.

    Writes weights (state dict), the resolved config, the audio normalisers, loss.png (training
    and validation loss per epoch) and an ONNX export (plus a stateful one-step ONNX model for
    the causal recurrent ones, LSTM and aud2motion, which `live` runs) into the --out folder.
    """
    from gesturebank.cli.train import train_command

    with user_errors():
        config = resolve_config(config_file=config_file, sets=sets, flags={})
        result = train_command(
            dataset=dataset,
            model=model,
            variant=variant,
            fold=fold,
            subject=subject,
            out_dir=out_dir,
            config=config.train,
            quiet=quiet,
            epochs=epochs,
        )
    out.print(result.stop_line(), highlight=False, soft_wrap=True)
    out.print(
        f"model written to {out_dir} (loss curves: loss.png)", highlight=False, soft_wrap=True
    )


def evaluate(
    model_dir: Annotated[
        Path | None,
        typer.Argument(
            help="A model folder written by `train`; with --timelines and no model, the dataset.",
            show_default=False,
        ),
    ] = None,
    dataset: Annotated[
        Path | None, typer.Argument(help="Dataset (default: the one it was trained on).")
    ] = None,
    split: Annotated[SplitPart, typer.Option(help="Split part.")] = "test",
    timelines: Annotated[
        list[Path] | None,
        typer.Option(
            "--timelines",
            help="A folder of angle timelines another system produced, one per clip of the "
            "split part, named by clip id (CLIP_ID.csv, as `synthesize` writes them); scored "
            "as a row named by the folder (repeatable).",
        ),
    ] = None,
    variant: Annotated[
        Variant | None,
        typer.Option(help="Without a model: the split, 'si' (a fold; the default) or 'sd'."),
    ] = None,
    fold: Annotated[int | None, typer.Option(help="Without a model: SI fold (default 0).")] = None,
    subject: Annotated[str | None, typer.Option(help="Without a model: SD subject.")] = None,
    config_file: ConfigOption = None,
    sets: SetOption = None,
) -> None:
    """Score a model like Table 5.1 of the dissertation, per subject and averaged.

    L, RMSE, ΔLCCA, LCCA_Θ, ΔJ̃, CCA, FCCA, APE, and the field's measures (GENEA's acceleration,
    jerk, speed/acceleration Hellinger distances and FGD; BEAT's beat consistency), next to four
    baselines (natural motion, the static mean pose, a shuffled clip, the ground truth shifted in
    time); metrics.json is written into the model folder.

    Another system's output is scored the same way from angle timelines: `evaluate MODEL
    --timelines DIR` (beside the model, on its split), or without a model `evaluate DATASET
    --timelines DIR [--fold N | --variant sd --subject S]` (scoring config: --config/--set).
    """
    from gesturebank.cli.train import evaluate_command, evaluate_timelines_command
    from gesturebank.train.model_folder import MODEL_JSON

    with user_errors():
        if model_dir is None:
            raise InputError("evaluate needs a model folder (or a dataset with --timelines)")
        is_model = (model_dir / MODEL_JSON).is_file()
        split_options = variant, fold, subject, config_file, sets
        if is_model and any(o is not None for o in split_options):
            raise InputError(
                f"{model_dir}: a model is scored on its own split with its own config; "
                "--variant/--fold/--subject/--config/--set are for timelines without a model"
            )
        if timelines and not is_model and dataset is None:  # `evaluate DATASET --timelines DIR`
            config = resolve_config(config_file=config_file, sets=sets, flags={}).train
            evaluate_timelines_command(
                timelines,
                model_dir,
                split,
                variant=variant or "si",
                fold=fold,
                subject=subject,
                config=config,
                console=out,
            )
            return
        evaluate_command(
            model_dir=model_dir,
            dataset=dataset,
            split=split,
            timelines=timelines or (),
            console=out,
        )


def compare(
    model_dirs: Annotated[
        list[Path], typer.Argument(help="Model folders written by `train`, all on one split.")
    ],
    dataset: Annotated[
        Path | None,
        typer.Option(help="Dataset (default: the one the models were trained on)."),
    ] = None,
    split: Annotated[SplitPart, typer.Option(help="Split part.")] = "test",
    table_out: Annotated[
        Path | None, typer.Option("--out", help="Also write the table: a .csv or .md file.")
    ] = None,
    config_file: ConfigOption = None,
    sets: SetOption = None,
) -> None:
    """Score several models and the baselines (natural motion, mean pose, a shuffled clip, the
    shifted truth) on one split: one table of the seeds' and the field's measures (GENEA's
    acceleration, jerk, Hellinger distances and FGD — its autoencoder's version in the title —
    and BEAT's beat consistency), each the mean over subjects.
    """
    from gesturebank.train.eval.compare import compare_command

    with user_errors():
        config = (
            resolve_config(config_file=config_file, sets=sets, flags={}).train
            if config_file or sets
            else None
        )
        compare_command(
            model_dirs=model_dirs,
            dataset=dataset,
            split=split,
            config=config,
            out=table_out,
            console=out,
        )
    if table_out is not None:
        out.print(f"table written to {table_out}", highlight=False, soft_wrap=True)


def synthesize(
    model_dir: ModelDirArg,
    audio: Annotated[Path, typer.Argument(help="Speech: a WAV or any file with an audio track.")],
    out_csv: Annotated[Path, typer.Option("--out", help="CSV of angles to write.")] = Path(
        "angles.csv"
    ),
    znorm: Annotated[
        str, typer.Option(help="Audio z-norm stats: '*' (whole dataset), a subject, or 'self'.")
    ] = "*",
) -> None:
    """Offline synthesis: speech → the 11 Pepper angles at 100 Hz, as a CSV for `replay`.

    Audio features → model → inverse normalisation → Butterworth post-smoothing (§4.4.1) →
    clamp; the CSV is an angle timeline: a `#` line naming the robot profile, unit and reach
    mode, then a time_s column and one column per joint (radians).
    """
    from gesturebank.train.synthesis import synthesize as synthesize_angles

    with user_errors():
        angles = synthesize_angles(
            model_dir=model_dir, audio_path=audio, out_csv=out_csv, znorm=znorm
        )
    out.print(f"{len(angles)} frames written to {out_csv}", highlight=False, soft_wrap=True)
