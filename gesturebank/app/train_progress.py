"""A training run's epochs on the terminal (`train.trainer.EpochProgress`): a live bar on a
terminal; otherwise (a log, a pipe) one plain line per epoch."""

from __future__ import annotations

from rich.console import Console
from rich.progress import BarColumn, Progress, TaskID, TextColumn, TimeElapsedColumn


class EpochBar:
    """Shows each stage of a training run as a bar (one line per epoch when not on a terminal)."""

    def __init__(self, console: Console | None = None) -> None:
        self.console = console or Console()
        self.plain = not self.console.is_terminal  # a log gets a line per epoch, not a bar
        self._bar: Progress | None = None
        self._task: TaskID | None = None
        self._description, self._max_epochs = "", 0

    def begin(self, description: str, max_epochs: int) -> None:
        self._description, self._max_epochs = description, max_epochs
        if self.plain:
            return
        self._bar = Progress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            TextColumn("epoch {task.completed:.0f}/{task.total:.0f}"),
            TextColumn("{task.fields[losses]}"),
            TimeElapsedColumn(),
            transient=False,
            console=self.console,
        )
        self._bar.start()
        self._task = self._bar.add_task(description, total=max_epochs, losses="")

    def epoch(self, epoch: int, losses: str) -> None:
        if self._bar is not None and self._task is not None:
            self._bar.update(self._task, completed=epoch, losses=losses)
        else:
            self.console.print(
                f"{self._description}: epoch {epoch}/{self._max_epochs}  {losses}",
                highlight=False,
                markup=False,
                soft_wrap=True,
            )

    def end(self, epochs: int) -> None:
        if self._bar is not None and self._task is not None:
            self._bar.update(self._task, total=epochs)
            self._bar.stop()
        self._bar, self._task = None, None
