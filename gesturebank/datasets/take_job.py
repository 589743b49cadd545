"""One take as a job of the build: run it in a worker and write it, record its failure, and
read back what a worker wrote when its result never arrived. The local pool (`datasets.build`)
and the Ray executor (`datasets.cluster`) both run takes through it.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from gesturebank.config import Config
from gesturebank.datasets import store
from gesturebank.datasets.pipeline import CONTENT_SECTIONS, lifter_name
from gesturebank.datasets.takes import Take
from gesturebank.errors import GesturebankError

log = logging.getLogger(__name__)

Outcome = Literal["built", "skipped", "failed"]


@dataclass(frozen=True)
class TakeResult:
    """What a worker reports of one take: timings and what it gave."""

    take_id: str
    outcome: Outcome
    reason: str = ""
    wall_s: float = 0.0
    video_s: float = 0.0
    detect_s: float = 0.0
    clips: int = 0
    usable_s: float = 0.0


def content_digest(config: Config) -> str:
    return config.digest(*CONTENT_SECTIONS)


def run_take(take: Take, source: str, out: Path, config: Config) -> TakeResult:
    """Build one take and write it; every failure becomes a `failed` record, never an exception."""
    from gesturebank.datasets.pipeline import build_take

    start = time.perf_counter()
    try:
        built = build_take(take, source, config)
    except GesturebankError as exc:
        reason = str(exc)
    except Exception as exc:  # a bug or a library error must not stop the other takes
        log.exception("%s: unexpected error", take.video)
        reason = f"{take.video}: unexpected {type(exc).__name__}: {exc}"
    else:
        try:
            store.write_take(out, built.record, built.clips, built.preview)
        except OSError as exc:  # a full disk or quota: nothing of it stays under a final name
            reason = f"{store.take_dir(out, take.take_id)}: cannot write ({exc.strerror or exc})"
        else:
            return TakeResult(
                take.take_id,
                "built",
                "",
                time.perf_counter() - start,
                built.record.seconds,
                built.detect_s,
                len(built.clips),
                built.record.usable_s,
            )
    return record_failure(take, source, out, config, reason, time.perf_counter() - start)


def record_failure(
    take: Take, source: str, out: Path, config: Config, reason: str, wall_s: float = 0.0
) -> TakeResult:
    record = store.TakeRecord(
        take_id=take.take_id,
        subject=take.subject,
        source=source,
        config_digest=content_digest(config),
        failed=reason,
        detector=config.detector.name,
        lifter=lifter_name(take, config),
        traits=take.traits,
    )
    try:
        store.write_take(out, record)
    except OSError as exc:  # the disk is full: the summary still reports the failure
        log.warning("%s: cannot record the failure (%s)", take.take_id, exc.strerror or exc)
    return TakeResult(take.take_id, "failed", reason, wall_s)


def record_stamp(out: Path, take_id: str) -> tuple[int, int] | None:
    """Identity of a take's record file: records are replaced whole, so a rewrite changes it."""
    try:
        st = store.take_json(out, take_id).stat()
    except OSError:
        return None
    return st.st_ino, st.st_mtime_ns


def written_result(out: Path, take_id: str) -> TakeResult | None:
    """The result of a take written in this run whose result never reached us (interrupt)."""
    record = store.read_record(out, take_id)
    if record is None:
        return None
    if record.failed:
        return TakeResult(take_id, "failed", record.failed)
    return TakeResult(
        take_id,
        "built",
        video_s=record.seconds,
        clips=len(record.data_clips),
        usable_s=record.usable_s,
    )
