"""The build's progress as a person watches it (rich; nothing with --quiet): takes done, video
frames done, frames per second and the time left, counted in video frames so that one long video
moves the bar too — per chunk when its detection is split into chunks (`take_job.Schedule`).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from datetime import timedelta
from types import TracebackType

from rich.console import Console
from rich.progress import (
    BarColumn,
    Progress,
    ProgressColumn,
    Task,
    TextColumn,
)
from rich.table import Column
from rich.text import Text

from gesturebank.datasets.take_job import TakeResult
from gesturebank.datasets.takes import Take
from gesturebank.errors import GesturebankError

log = logging.getLogger(__name__)

COLOUR = {"built": "green", "skipped": "cyan", "failed": "red"}


def take_frames(take: Take) -> int:
    """Video frames of a take as its headers give them (a multi-camera take: its first camera;
    a motion-capture take or an unreadable video: 0, so it only counts as a take)."""
    from gesturebank.extract.video import probe

    if take.mocap:
        return 0
    video = take.videos[0] if take.videos else take.video
    try:
        info = probe(video)
    except (GesturebankError, OSError) as exc:  # the build reports it as the take's failure
        log.debug("%s: no frame count (%s)", video, exc)
        return 0
    if info.n_frames:
        return info.n_frames
    guess = info.duration_s * info.fps
    return round(guess) if guess == guess and guess > 0 else 0  # NaN: unknown


class _Counts(ProgressColumn):
    """`takes 2/3 · 541/1,082 frames · 83 frames/s · ETA 0:00:07`: the rate over the last half
    minute (rich's estimate), the time left at that rate."""

    def render(self, task: Task) -> Text:
        speed = task.finished_speed or task.speed
        rate = f"{speed:,.0f} frames/s" if speed else "– frames/s"
        left = task.time_remaining
        eta = "–" if left is None else str(timedelta(seconds=round(left)))
        return Text(
            f"{task.fields['takes']} · {task.completed:,.0f}/{task.total or 0:,.0f} frames · "
            f"{rate} · ETA {eta}",
            style="cyan",
        )


class BuildProgress:
    """`with BuildProgress(takes, console) as p:` then `p.result(r)` as each take ends and
    `p.chunk(take_id, done, total)` as a chunk of a long video is detected."""

    def __init__(self, takes: Sequence[Take], console: Console) -> None:
        self.frames = {t.take_id: take_frames(t) for t in takes}
        self.counted = dict.fromkeys(self.frames, 0)  # frames already on the bar, per take
        self.n_takes, self.n_done = len(takes), 0
        self.progress = Progress(
            TextColumn("[bold]build[/bold]", table_column=Column(no_wrap=True, min_width=5)),
            BarColumn(bar_width=10),
            _Counts(table_column=Column(no_wrap=True)),
            TextColumn(
                "{task.description}", table_column=Column(no_wrap=True, overflow="ellipsis")
            ),
            console=console,
            transient=False,
        )
        total = max(1, sum(self.frames.values()))
        self.task = self.progress.add_task("", total=total, takes=self._takes())

    def _takes(self) -> str:
        return f"takes {self.n_done}/{self.n_takes}"

    def __enter__(self) -> BuildProgress:
        self.progress.__enter__()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.progress.__exit__(kind, exc, tb)

    def result(self, result: TakeResult) -> None:
        """A take ended: its frames are done (a skipped take's leave the total: they cost no
        time, and counting them would make the rate and the time left lie)."""
        self.n_done += 1
        frames = self.frames.get(result.take_id, 0)
        left = frames - self.counted.get(result.take_id, 0)
        self.counted[result.take_id] = frames
        c = COLOUR.get(result.outcome, "white")
        description = f"[{c}]{result.outcome}[/{c}] {result.take_id}"
        if result.outcome == "skipped":
            total = self.progress.tasks[0].total or 1
            self.progress.update(
                self.task, total=max(1, total - left), takes=self._takes(), description=description
            )
            return
        self.progress.update(self.task, advance=left, takes=self._takes(), description=description)

    def chunk(self, take_id: str, done: int, total: int) -> None:
        """`done` of the `total` chunks of a long take are detected: that share of its frames."""
        frames = round(self.frames.get(take_id, 0) * done / max(1, total))
        step = max(0, frames - self.counted.get(take_id, 0))
        self.counted[take_id] = self.counted.get(take_id, 0) + step
        self.progress.update(
            self.task, advance=step, description=f"{take_id}: chunk {done}/{total} detected"
        )
