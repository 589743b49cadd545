"""`gesturebank train`, `evaluate`, `compare` and `synthesize`: their options. The work is done by
plain functions imported when a command runs (`cli.training`: training and scoring; the
comparison is `train.eval.compare`'s, offline synthesis `train.synthesis`'s), so that the CLI
starts without torch.

The model folder they write and read is `train.model_folder`'s (its docstring lists the files).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from gesturebank.cli.options import (
    ConfigOption,
    DatasetArg,
    ForceOption,
    ModelDirArg,
    QuietOption,
    SetOption,
    SplitPart,
    one_of,
    pick,
    resolve_config,
)
from gesturebank.cli.terminal import out, user_errors
from gesturebank.config import Target, Variant
from gesturebank.errors import InputError
from gesturebank.fileio import keep_existing
from gesturebank.train.registry import MODELS


def train_cmd(
    dataset: DatasetArg,
    *,
    model: Annotated[str, typer.Option(help=f"The network, {one_of(MODELS)}.")] = "mlp",
    variant: Annotated[
        Variant | None,
        typer.Option(
            parser=pick(Variant),
            help="'si' subject-independent (a fold), 'sd' (one subject) or 'dyadic' (seed 004's "
            "85/10/5 split, a clip always with its partner: splits/dyadic.json). Default: si "
            "when the dataset has 3 subjects or more, else sd of its one subject.",
            show_default=False,
        ),
    ] = None,
    target: Annotated[
        Target | None,
        typer.Option(
            parser=pick(Target),
            help="What the model predicts: 'speaker' (the person's motion from their speech) or "
            "'listener' (a listener's head from the partner's speech and speaking flag, loss on "
            "listening frames; needs paired clips). Default: train.target ('speaker').",
            show_default=False,
        ),
    ] = None,
    fold: Annotated[int | None, typer.Option(help="SI fold (default 0).")] = None,
    subject: Annotated[str | None, typer.Option(help="SD subject.")] = None,
    out_dir: Annotated[
        Path,
        typer.Option(
            "--out", help="Model folder to write (with --force an older one is replaced whole)."
        ),
    ] = Path("model"),
    epochs: Annotated[
        int | None,
        typer.Option(
            min=1,
            help="Most epochs to train (replaces the model's [train.MODEL] max_epochs); early "
            "stopping may end sooner.",
        ),
    ] = None,
    require: Annotated[
        str | None,
        typer.Option(
            help="Body parts every training clip must have: head, arms, left_arm, right_arm or "
            "joined by + (head+arms). Default: what the model's targets need (a whole-body "
            "model: any clip, unknown joints masked).",
        ),
    ] = None,
    config_file: ConfigOption = None,
    sets: SetOption = None,
    quiet: QuietOption = False,
    force: ForceOption = False,
) -> None:
    """Train a speech-to-motion model on a dataset split: the dissertation's MLP or LSTM (§4.3)
    or a seed model — aud2motion (causal GRU), aud2pose (BiGRU window), aud2repr2pose (motion
    autoencoder, then speech to its code), blstm (span predictor), cvae (sampled motion), dcccae
    (CCA-coupled autoencoders) — each with its paper's optimiser and schedule ([train.NAME]).

    Training stops early when the validation loss stops falling (train.patience), else at the
    epoch limit; the last line says which. On a terminal a progress bar shows the losses; in a
    log, one line per epoch.

    --target listener (seed 004) trains on the clips that have a partner (build.people = "all"):
    the listener's head (HeadPitch, HeadYaw) on its listening frames, from the speech and the
    partner's speaking flag; a causal one (lstm, aud2motion, mlp) can run `live --role listener`.

    Writes weights (state dict), the resolved config, the audio normalisers, loss.png (training
    and validation loss per epoch) and an ONNX export (plus a stateful one-step ONNX model for
    the causal recurrent ones, LSTM and aud2motion, which `live` runs) into the --out folder.
    """
    from gesturebank.cli.training import train_command

    with user_errors():
        MODELS.check(model)  # a mistyped name first: it says more than the output's policy
        keep_existing([out_dir], force=force)
        config = resolve_config(
            config_file=config_file, sets=sets, flags={"train": {"target": target}}
        )
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
            require=require,
            on_warning=lambda message: typer.echo(f"warning: {message}", err=True),
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
    *,
    dataset: Annotated[
        Path | None, typer.Argument(help="Dataset (default: the one it was trained on).")
    ] = None,
    split: Annotated[SplitPart, typer.Option(parser=pick(SplitPart), help="Split part.")] = "test",
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
        typer.Option(
            parser=pick(Variant),
            help="Without a model: the split, 'si' (a fold; the default), 'sd' or 'dyadic'.",
        ),
    ] = None,
    fold: Annotated[int | None, typer.Option(help="Without a model: SI fold (default 0).")] = None,
    subject: Annotated[str | None, typer.Option(help="Without a model: SD subject.")] = None,
    require: Annotated[
        str | None,
        typer.Option(
            help="Without a model: body parts every scored clip must have (head, arms, "
            "head+arms, ...). A model is scored on the parts it was trained on.",
        ),
    ] = None,
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
    from gesturebank.cli.training import evaluate_command, evaluate_timelines_command
    from gesturebank.train.model_folder import MODEL_JSON

    with user_errors():
        if model_dir is None:
            raise InputError("evaluate needs a model folder (or a dataset with --timelines)")
        is_model = (model_dir / MODEL_JSON).is_file()
        split_options = variant, fold, subject, require, config_file, sets
        if is_model and any(o is not None for o in split_options):
            raise InputError(
                f"{model_dir}: a model is scored on its own split with its own config; "
                "--variant/--fold/--subject/--require/--config/--set are for timelines without "
                "a model"
            )
        if timelines and not is_model and dataset is None:  # `evaluate DATASET --timelines DIR`
            config = resolve_config(config_file=config_file, sets=sets, flags={}).train
            evaluate_timelines_command(
                timelines,
                dataset=model_dir,
                split=split,
                variant=variant or "si",
                fold=fold,
                subject=subject,
                config=config,
                console=out,
                require=require,
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
    *,
    dataset: Annotated[
        Path | None,
        typer.Option(help="Dataset (default: the one the models were trained on)."),
    ] = None,
    split: Annotated[SplitPart, typer.Option(parser=pick(SplitPart), help="Split part.")] = "test",
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
    from gesturebank.app.compare import compare_command

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
    *,
    audio: Annotated[Path, typer.Argument(help="Speech: a WAV or any file with an audio track.")],
    out_csv: Annotated[Path, typer.Option("--out", help="CSV of angles to write.")] = Path(
        "angles.csv"
    ),
    znorm: Annotated[
        str, typer.Option(help="Audio z-norm stats: '*' (whole dataset), a subject, or 'self'.")
    ] = "*",
    force: ForceOption = False,
) -> None:
    """Offline synthesis: speech → the 11 Pepper angles at 100 Hz, as a CSV for `replay`.

    Audio features → model → inverse normalisation → Butterworth post-smoothing (§4.4.1) →
    clamp; the CSV is an angle timeline: a `#` line naming the robot profile, unit and reach
    mode, then a time_s column and one column per joint (radians).
    """
    from gesturebank.train.synthesis import synthesize as synthesize_angles

    with user_errors():
        keep_existing([out_csv], force=force)
        angles = synthesize_angles(
            model_dir=model_dir, audio_path=audio, out_csv=out_csv, znorm=znorm
        )
    out.print(f"{len(angles)} frames written to {out_csv}", highlight=False, soft_wrap=True)
