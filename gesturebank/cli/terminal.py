"""What the commands show and how they end: the console, the exit codes, one-line errors."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import typer
from rich.console import Console

from gesturebank.errors import GesturebankError, RobotError

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2
out = Console()


@contextmanager
def user_errors() -> Iterator[None]:
    """Show a GesturebankError as one line; exit 1 when the robot failed, 2 for bad input."""
    try:
        yield
    except GesturebankError as exc:
        # plain echo, not rich: a one-line error must not be wrapped at the terminal width
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(EXIT_FAILED if isinstance(exc, RobotError) else EXIT_USAGE) from None
