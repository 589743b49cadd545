"""Issue 33 item 7: the build's progress counts video frames (per take, per chunk), not takes;
a take being detected has a line of its own (rich on a terminal, plain lines in a log)."""

from __future__ import annotations

import io
import math
import multiprocessing
import re
from pathlib import Path

import pytest
from rich.console import Console

from gesturebank.app import frame_board
from gesturebank.app.frame_board import FrameBoard
from gesturebank.app.progress import BuildProgress, take_frames, take_video
from gesturebank.app.take_job import TakeResult
from gesturebank.datasets.takes import Take
from gesturebank.extract.frame_watch import watcher
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


def test_a_take_has_its_own_line_while_it_is_detected(samples: Path) -> None:
    """On a terminal: the take's frames done of its frames (frames/s and ETA once known); gone
    at its end."""
    long = Take("long", "s", samples / "talking" / "lab" / "cam03_arctic.mp4")
    frames, fps = take_video(long)
    screen = Console(file=io.StringIO(), force_terminal=True, width=200)
    with BuildProgress([long], screen) as progress:
        progress.frames("long", 1.0)
        expected = round(fps)  # one second of the video
        recorded = Console(record=True, width=200, file=io.StringIO())
        recorded.print(progress.progress.make_tasks_table(progress.progress.tasks))
        text = recorded.export_text()
        take_line = next(ln for ln in text.splitlines() if ln.lstrip().startswith("take"))
        assert f"{expected:,}/{frames:,} frames" in take_line and "long" in take_line
        assert "–" not in take_line  # no rate yet: none shown, not a `– frames/s` (issue 44)
        assert progress.progress.tasks[0].completed == expected
        progress.frames("long", 0.5)  # a late report never moves it back
        assert progress.progress.tasks[0].completed == expected
        progress.result(TakeResult("long", "built"))
        progress.frames("long", 2.0)  # the board still holds an ended take's last frame
        assert len(progress.progress.tasks) == 1  # the build's line alone


def test_plain_lines_name_the_take_and_reach_its_frames(samples: Path) -> None:
    """Not a terminal (a log): plain lines per take, the last one at its frame count."""
    long = Take("long", "s", samples / "talking" / "lab" / "cam03_arctic.mp4")
    frames, fps = take_video(long)
    text = io.StringIO()
    with BuildProgress([long], Console(file=text, width=200)) as progress:
        progress.frames("long", 1.0)
        progress.chunk("long", 1, 2)
        progress.result(TakeResult("long", "built"))
    lines = [ln for ln in text.getvalue().splitlines() if ln.startswith("long · ")]
    assert lines[0].startswith(f"long · {round(fps):,}/{frames:,} frames")
    assert lines[-1].startswith(f"long · {frames:,}/{frames:,} frames") and "built" in lines[-1]
    assert "–" not in text.getvalue()
    assert "\x1b" not in text.getvalue()  # plain: no terminal codes


def test_frame_board_sums_a_takes_jobs_from_their_starts() -> None:
    board = FrameBoard(multiprocessing.get_context("spawn"), 3)
    take = board.claim("long", 0.0)
    chunk = board.claim("long", 30.0)  # a chunk from 30 s on
    board.claim("short", 0.0)  # not started: not reported
    board.values[take] = 12.5
    board.values[chunk] = 32.0
    assert board.seconds() == {"long": 14.5}


def test_watched_stores_the_latest_frame_time(monkeypatch: pytest.MonkeyPatch) -> None:
    values = [math.nan, math.nan]
    monkeypatch.setattr(frame_board, "_BOARD", values)

    def detect(times: list[float]) -> str:
        watch = watcher()
        assert watch is not None
        for t in times:
            watch(t)
        return "done"

    assert frame_board.watched(1, detect, [0.0, 0.04, 0.08, 0.0]) == "done"  # 2nd camera: 0.0
    assert values[1] == 0.08 and math.isnan(values[0])
    assert watcher() is None  # only inside


def test_the_lines_fit_80_columns(samples: Path) -> None:
    """Issue 44: at 80 columns the build's line was cut (`ETA 0:0… built lab__cam01_`) and
    showed `– frames/s`. Every line fits, take ids whole, no placeholder dash."""
    takes = [
        Take(f"lab__{name}_arctic", "lab", samples / "talking" / "lab" / f"{name}_arctic.mp4")
        for name in ("cam01", "cam03")
    ]
    screen = io.StringIO()
    console = Console(file=screen, force_terminal=True, width=80)
    with BuildProgress(takes, console) as progress:
        for take in takes:
            progress.frames(take.take_id, 0.5)
        progress.progress.tasks[0].finished_speed = 123456.0  # a rate as wide as they come
        recorded = Console(record=True, width=80, file=io.StringIO())
        recorded.print(progress.progress.make_tasks_table(progress.progress.tasks))
        live = recorded.export_text()
        progress.result(TakeResult(takes[0].take_id, "built"))
    for line in live.splitlines():
        assert len(line.rstrip()) <= 80 and "…" not in line, line
    assert "123,456/s" in live and "–" not in live
    assert all(t.take_id in live for t in takes)  # each take's own line names it whole
    plain = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", screen.getvalue())
    assert f"built {takes[0].take_id}\n" in plain  # its end: a line of its own


def test_a_log_at_80_columns_ends_with_a_whole_line(samples: Path) -> None:
    """Not a terminal, 80 columns: the build's last line was cut (`ETA 00… built lab__cam01_`)."""
    long = Take("lab__cam01_arctic", "lab", samples / "talking" / "lab" / "cam01_arctic.mp4")
    text = io.StringIO()
    with BuildProgress([long], Console(file=text, width=80)) as progress:
        progress.frames(long.take_id, 1.0)
        progress.result(TakeResult(long.take_id, "built"))
    lines = text.getvalue().splitlines()
    assert lines and all(len(ln) <= 80 and "…" not in ln for ln in lines), lines
    assert sum(long.take_id in ln for ln in lines) >= 1  # its plain line names it whole
