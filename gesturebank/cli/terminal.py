"""What the commands show and how they end: the console, the exit codes, one-line errors."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import typer
from rich.console import Console

from gesturebank.errors import GesturebankError, RobotError

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2
out = Console()
# The modules of the optional extras (pyproject.toml), for a one-line error when one is missing.
EXTRA_OF = {
    "torch": "train",
    "onnx": "train",
    "qi": "robot",
    "sounddevice": "robot",
    "open3d": "multiview",
    "pycolmap": "multiview",
    "ray": "distributed",
}


@contextmanager
def missing_extras() -> Iterator[None]:
    """A module of an extra that is not installed: one line naming the extra, exit 2."""
    try:
        yield
    except ModuleNotFoundError as exc:
        extra = EXTRA_OF.get((exc.name or "").partition(".")[0])
        if extra is None:
            raise
        typer.echo(
            f"error: this command needs {exc.name}, in gesturebank's {extra!r} extra: "
            f'`make setup` (every extra) or `pip install -e ".[{extra}]"`',
            err=True,
        )
        raise SystemExit(EXIT_USAGE) from None


@contextmanager
def user_errors() -> Iterator[None]:
    """Show a GesturebankError as one line; exit 1 when the robot failed, 2 for bad input."""
    try:
        yield
    except GesturebankError as exc:
        # plain echo, not rich: a one-line error must not be wrapped at the terminal width
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(EXIT_FAILED if isinstance(exc, RobotError) else EXIT_USAGE) from None
