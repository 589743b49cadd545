"""The build's progress as a person watches it (rich; nothing with --quiet): takes done, video
frames done, frames per second and the time left, counted in video frames so that one long video
moves the bar too — per chunk when its detection is split into chunks (`take_job.Schedule`).

While a take is detected it has a line of its own: its frames done of its frames, frames/s and
the time left, fed every `frame_board.POLL_S` from the workers' frame loops (`frames`). When the
console is not a terminal (a log), each take prints a plain line instead, at most every
`PLAIN_EVERY_S` and once when it ends.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from datetime import timedelta
from types import TracebackType

from rich.console import Console
from rich.progress import (
    BarColumn,
    Progress,
    ProgressColumn,
    Task,
    TaskID,
    TextColumn,
)
from rich.table import Column
from rich.text import Text

from gesturebank.app import NARROW_COLUMNS
from gesturebank.app.take_job import TakeResult
from gesturebank.datasets.takes import Take
from gesturebank.errors import GesturebankError

log = logging.getLogger(__name__)

COLOUR = {"built": "green", "skipped": "cyan", "failed": "red"}
PLAIN_EVERY_S = 10.0  # a take's plain progress line (not a terminal) at most this often


def take_video(take: Take) -> tuple[int, float]:
    """(video frames, frames per second) of a take as its headers give them (a multi-camera
    take: its first camera's; a motion-capture take or an unreadable video: (0, 0), so it only
    counts as a take)."""
    from gesturebank.extract.video import probe

    if take.mocap:
        return 0, 0.0
    video = take.videos[0] if take.videos else take.video
    try:
        info = probe(video)
    except (GesturebankError, OSError) as exc:  # the build reports it as the take's failure
        log.debug("%s: no frame count (%s)", video, exc)
        return 0, 0.0
    fps = info.fps if info.fps == info.fps and info.fps > 0 else 0.0  # NaN: unknown
    if info.n_frames:
        return info.n_frames, fps
    guess = info.duration_s * info.fps
    return (round(guess), fps) if guess == guess and guess > 0 else (0, 0.0)


def take_frames(take: Take) -> int:
    """Video frames of a take (`take_video`)."""
    return take_video(take)[0]


def _eta(seconds: float) -> str:
    """0:07 under an hour, 1:02:03 from one."""
    text = str(timedelta(seconds=round(seconds)))
    return text.removeprefix("0:")


def _rate_and_eta(speed: float | None, left_s: float | None, *, narrow: bool = False) -> str:
    """` · 83 frames/s · ETA 0:07` (`narrow`: `83/s`); nothing before the rate is known, not
    a `–` placeholder."""
    if not speed:
        return ""
    rate = f"{speed:,.0f}/s" if narrow else f"{speed:,.0f} frames/s"
    return f" · {rate}" + ("" if left_s is None else f" · ETA {_eta(left_s)}")


class _Counts(ProgressColumn):
    """`takes 2/3 · 541/1,082 frames · 83 frames/s · ETA 0:07`: the rate over the last half
    minute (rich's estimate), the time left at that rate; `narrow`: `… · 83/s · …`."""

    def __init__(self, *, narrow: bool, table_column: Column) -> None:
        super().__init__(table_column=table_column)
        self.narrow = narrow

    def render(self, task: Task) -> Text:
        speed = task.finished_speed or task.speed
        label = f"{task.fields['takes']} · " if task.fields["takes"] else ""
        tail = _rate_and_eta(speed, task.time_remaining, narrow=self.narrow)
        return Text(
            f"{label}{task.completed:,.0f}/{task.total or 0:,.0f} frames{tail}", style="cyan"
        )


class BuildProgress:
    """`with BuildProgress(takes, console) as p:` then `p.result(r)` as each take ends,
    `p.chunk(take_id, done, total)` as a chunk of a long video is detected and
    `p.frames(take_id, seconds)` as a take's video is detected."""

    def __init__(self, takes: Sequence[Take], console: Console) -> None:
        video = {t.take_id: take_video(t) for t in takes}
        self.total_frames = {take_id: n for take_id, (n, _) in video.items()}
        self.fps = {take_id: fps for take_id, (_, fps) in video.items()}
        self.counted = dict.fromkeys(self.total_frames, 0)  # frames already on the bar, per take
        self.n_takes, self.n_done = len(takes), 0
        self.console = console
        self.plain = not console.is_terminal  # a log: plain lines per take, no live lines
        # a narrow terminal: compact counts, a shorter bar, each take's end a line of its own
        self.narrow = console.width < NARROW_COLUMNS  # a log too: its last line is printed
        self.take_tasks: dict[str, TaskID] = {}
        # per take in plain mode: (time, frames) first seen, time of its last line
        self.started: dict[str, tuple[float, int]] = {}
        self.said: dict[str, float] = {}
        self.ended: set[str] = set()
        self.progress = Progress(
            TextColumn("{task.fields[name]}", table_column=Column(no_wrap=True, min_width=5)),
            BarColumn(bar_width=6 if self.narrow else 10),
            _Counts(narrow=self.narrow, table_column=Column(no_wrap=True)),
            TextColumn(
                "{task.description}", table_column=Column(no_wrap=True, overflow="ellipsis")
            ),
            console=console,
            transient=False,
        )
        total = max(1, sum(self.total_frames.values()))
        self.task = self.progress.add_task(
            "", total=total, takes=self._takes(), name="[bold]build[/bold]"
        )

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
        frames = self.total_frames.get(result.take_id, 0)
        left = frames - self.counted.get(result.take_id, 0)
        self._take_ended(result)
        self.counted[result.take_id] = frames
        c = COLOUR.get(result.outcome, "white")
        description = f"[{c}]{result.outcome}[/{c}] {result.take_id}"
        if self.narrow:  # above the live lines, whole, instead of cut at the bar's end
            if not self.plain:  # a log has said it in the take's plain line
                self.progress.console.print(description, highlight=False, soft_wrap=True)
            description = ""
        if result.outcome == "skipped":
            total = self.progress.tasks[0].total or 1
            self.progress.update(
                self.task, total=max(1, total - left), takes=self._takes(), description=description
            )
            return
        self.progress.update(self.task, advance=left, takes=self._takes(), description=description)

    def chunk(self, take_id: str, done: int, total: int) -> None:
        """`done` of the `total` chunks of a long take are detected: that share of its frames."""
        frames = round(self.total_frames.get(take_id, 0) * done / max(1, total))
        what = f"{take_id}: chunk {done}/{total} detected"
        self._advance(take_id, frames, what)
        self.progress.update(self.task, description="" if self.narrow else what)

    def frames(self, take_id: str, seconds: float) -> None:
        """`seconds` of the take's video are detected (its own line: frames, frames/s, ETA)."""
        fps = self.fps.get(take_id, 0.0)
        if not fps or take_id not in self.total_frames:
            return
        self._advance(take_id, round(seconds * fps), take_id)

    def _advance(self, take_id: str, frames: int, description: str) -> None:
        """The take is `frames` far (never back): the build's bar and the take's line move.
        Nothing once it ended (the workers' board still holds its last frame)."""
        if take_id in self.ended:
            return
        total = self.total_frames.get(take_id, 0)
        done = min(total, max(frames, self.counted.get(take_id, 0)))
        step = done - self.counted.get(take_id, 0)
        self.counted[take_id] = done
        self.progress.update(self.task, advance=step)
        if not total:
            return
        if self.plain:
            self._plain_line(take_id, done, total)
            return
        if take_id not in self.take_tasks:
            self.take_tasks[take_id] = self.progress.add_task(
                take_id, total=total, takes="", name="take"
            )
        self.progress.update(self.take_tasks[take_id], completed=done, description=description)

    def _plain_line(self, take_id: str, done: int, total: int, end: str = "") -> None:
        """`take_id · 541/1,082 frames · 83 frames/s · ETA 0:07` (no colon: the summary's
        `take_id: …` lines stay the only ones of that shape), at most every
        `PLAIN_EVERY_S` per take unless it is the take's last (`end`: its outcome)."""
        now = time.monotonic()
        t0, f0 = self.started.setdefault(take_id, (now, done))
        if not end and now - self.said.get(take_id, -PLAIN_EVERY_S) < PLAIN_EVERY_S:
            return
        self.said[take_id] = now
        speed = (done - f0) / (now - t0) if now > t0 and done > f0 else None
        counts = _rate_and_eta(speed, None if end else (total - done) / speed if speed else None)
        tail = f" · {end}" if end else ""
        self.console.print(
            f"{take_id} · {done:,}/{total:,} frames{counts}{tail}",
            highlight=False,
            soft_wrap=True,
        )

    def _take_ended(self, result: TakeResult) -> None:
        """The take's own line goes (a terminal) or says how it ended (a log)."""
        self.ended.add(result.take_id)
        task = self.take_tasks.pop(result.take_id, None)
        if task is not None:
            self.progress.remove_task(task)
        total = self.total_frames.get(result.take_id, 0)
        if self.plain and result.outcome != "skipped" and total:
            done = total if result.outcome == "built" else self.counted.get(result.take_id, 0)
            self._plain_line(result.take_id, done, total, end=result.outcome)
