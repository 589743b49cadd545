"""Issue 33 item 7: the build's progress counts video frames (per take, per chunk), not takes."""

from __future__ import annotations

import io
from pathlib import Path

from rich.console import Console

from gesturebank.datasets.progress import BuildProgress, take_frames
from gesturebank.datasets.take_job import TakeResult
from gesturebank.datasets.takes import Take
from gesturebank.extract.video import probe


def test_progress_advances_by_frames_per_chunk_and_take(samples: Path, tmp_path: Path) -> None:
    long = Take("long", "s", samples / "talking" / "lab" / "cam03_arctic.mp4")
    short = Take("short", "s", samples / "talking" / "outdoor" / "sports2d_arctic.mp4")
    old = Take("old", "s", samples / "talking" / "lab" / "cam01_arctic.mp4")
    broken = tmp_path / "broken.mp4"
    broken.write_bytes(b"not a video")
    frames = {t.take_id: take_frames(t) for t in (long, short, old)}
    assert frames["long"] == probe(long.video).n_frames and frames["long"] > 100
    assert take_frames(Take("broken", "s", broken)) == 0  # the build reports it, not the bar
    text = io.StringIO()
    with BuildProgress([long, short, old], Console(file=text, width=200)) as progress:
        task = progress.progress.tasks[0]
        assert task.total == sum(frames.values())
        progress.result(TakeResult("old", "skipped"))  # costs no time: leaves the total
        assert task.total == frames["long"] + frames["short"] and task.completed == 0
        progress.chunk("long", 1, 4)
        assert task.completed == round(frames["long"] / 4)
        progress.chunk("long", 2, 4)
        assert task.completed == round(frames["long"] / 2)
        progress.result(TakeResult("long", "built"))
        assert task.completed == frames["long"]
        progress.result(TakeResult("short", "failed"))
        assert task.completed == task.total
    shown = text.getvalue()
    assert "takes 3/3" in shown and "frames/s" in shown and "ETA" in shown
