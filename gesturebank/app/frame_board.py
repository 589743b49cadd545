"""How far each running job of the build has got in its video, shared with the pool's workers.

One float per job (take or chunk), in shared memory the workers get when they start: a worker
stores the source time (s) of each frame it detects there (`extract.frame_watch`), a plain store
without a lock, so the frame loop is not slowed; the build reads the board as it waits for jobs
(`app.build`, every `POLL_S`) and reports each take's seconds of video detected. Per-frame
counts cross the process pool this way at no cost per frame beyond that store; the Ray executor
has no board (its progress is per chunk and per take).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from multiprocessing.context import BaseContext
from typing import Any

from gesturebank.datasets.lifeline import die_with
from gesturebank.extract.frame_watch import watching

POLL_S = 0.5  # how often the build reads the board: the progress refreshes no faster

_BOARD: Any = None  # a worker's view of the board (set by `start_worker`)


class FrameBoard:
    """`n` slots of frame times, NaN until a job's first frame; `claim` gives a job its slot."""

    def __init__(self, ctx: BaseContext, n: int) -> None:
        self.values = ctx.Array("d", [math.nan] * max(1, n), lock=False)
        self.jobs: list[tuple[str, float]] = []  # per slot: take id, the job's start in s

    def claim(self, take_id: str, start_s: float) -> int:
        """A slot for a job of `take_id` whose own frames start at `start_s` (a chunk's
        overlap before them, detected by two chunks, counts for neither)."""
        self.jobs.append((take_id, start_s))
        return len(self.jobs) - 1

    def seconds(self) -> dict[str, float]:
        """Seconds of video detected so far per take (the sum over its jobs)."""
        out: dict[str, float] = {}
        for slot, (take_id, start) in enumerate(self.jobs):
            t = self.values[slot]
            if t == t:  # not NaN: the job has seen a frame
                out[take_id] = out.get(take_id, 0.0) + max(0.0, t - start)
        return out


def start_worker(parent: int, board: Any) -> None:
    """Pool worker initialiser: die with the build (`lifeline`), keep the board's memory."""
    global _BOARD
    _BOARD = board
    die_with(parent)


def watched(slot: int, run: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """`run(*args, **kwargs)` in a worker, each frame's time stored in the board's `slot` (the
    latest of a take's videos: a second camera does not move it back)."""
    board = _BOARD
    if board is None:
        return run(*args, **kwargs)

    def store(t: float) -> None:
        if not board[slot] >= t:  # NaN or earlier
            board[slot] = t

    with watching(store):
        return run(*args, **kwargs)
