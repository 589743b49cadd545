"""A clip judged into records (issue 41): accepted, rejected whole, or cut around the stretches
that fail (`qc.stretches.judge`) into pieces and dropped spans — the same for the build
(`app.take.build_take`) and for re-judging (`datasets.refresh`, `gesturebank qc`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np

from gesturebank.clip import Clip
from gesturebank.config import QCConfig
from gesturebank.datasets.records import ClipRecord
from gesturebank.fileio import atomic_open
from gesturebank.qc.clip_metrics import ClipMetrics
from gesturebank.qc.metrics import clip_metrics
from gesturebank.qc.stretches import judge
from gesturebank.robot.pepper import RobotProfile


def judged_records(
    clip: Clip,
    *,
    qc: QCConfig,
    min_s: float,
    profile: RobotProfile,
    measured: str,
    trimmed: float | None,
    clip_ids: Iterator[str],
    span_ids: Iterator[str],
    keep_id: bool = False,
) -> tuple[list[Clip], list[ClipRecord]]:
    """The clips `clip` leaves after judging by `qc` (named from `clip_ids`; one not cut keeps
    its id with `keep_id`; a piece of at least `min_s` seconds is a clip) and the records of
    those and of the stretches cut out (kind "span", rejected, named from `span_ids`).
    trimmed: the take's trimmed_fraction, a metric of every clip of it (None: not measured)."""

    measure: Callable[[Clip], ClipMetrics] = lambda c: replace(  # noqa: E731
        clip_metrics(c, profile=profile, qc=qc), trimmed_fraction=trimmed
    )
    clips: list[Clip] = []
    rows: list[ClipRecord] = []
    for j in judge(clip, measure=measure, config=qc, profile=profile, min_s=min_s):
        if j.clip is None or j.metrics is None:
            span = ClipRecord(
                next(span_ids), "span", j.start_s, j.end_s, "rejected", j.reasons, person=-1
            )
            rows.append(span)
            continue
        # not cut: the clip keeps its id when `keep_id`; every piece is named from clip_ids
        keep = keep_id and j.clip is clip
        piece = j.clip if keep else replace(j.clip, clip_id=next(clip_ids))
        clips.append(piece)
        metrics, reasons = j.metrics.to_dict(), j.reasons
        rows.append(ClipRecord.of_clip(piece, metrics=metrics, reasons=reasons, measured=measured))
    return clips, rows


def write_clip(path: Path, clip: Clip) -> None:
    """Write one clip's arrays to `path` atomically (a piece cut out when re-judging)."""
    with atomic_open(path) as f:
        np.savez_compressed(f, allow_pickle=False, **clip.to_arrays())
