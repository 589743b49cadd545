"""One take as a job of the build: run it in a worker and write it, record its failure, and
read back what a worker wrote when its result never arrived. The local pool (`app.build`)
and the Ray executor (`app.cluster`) both run takes through it.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from gesturebank.app.views import lifter_name
from gesturebank.config import Config, VideoConfig
from gesturebank.datasets import store
from gesturebank.datasets.digest import content_digest as pipeline_digest
from gesturebank.datasets.takes import Take
from gesturebank.errors import GesturebankError
from gesturebank.extract.cache import DetectionCache

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
    cached: bool | None = None  # its detections came from the cache (None: not cached)


@dataclass(frozen=True)
class ChunkJob:
    """The detection of one chunk of a long video (`extract.chunks`), run before its take."""

    take_id: str
    video: Path
    range: VideoConfig  # the build's video settings, restricted to the chunk
    own_s: float = 0.0  # its first own frame's time (before it: the overlap, `extract.chunks`)


Job = ChunkJob | tuple[Take, str]  # a chunk, or a take with its source (relative path)


def chunk_cache(out: Path) -> DetectionCache:
    """Where the chunks of OUT_DIR's long videos are cached: in OUT_DIR, which every worker sees."""
    return DetectionCache(Path(out) / store.CHUNKS_DIR)


def chunk_jobs(take: Take, config: Config) -> list[ChunkJob]:
    """The chunk detections `take` can start with (its videos longer than build.chunk_s)."""
    from gesturebank.app.extract import take_chunks

    if take.mocap:
        return []
    jobs = []
    for video in take.videos or (take.video,):
        try:
            plan = take_chunks(str(video), config)
        except GesturebankError:  # the take's own task fails with the reason
            return []
        jobs += [ChunkJob(take.take_id, video, rng, chunk.own_s) for chunk, rng in plan]
    return jobs


def run_chunk(job: ChunkJob, *, out: Path, config: Config) -> None:
    """Detect one chunk into OUT_DIR's chunk cache. A chunk that fails is left to its take's
    task, which detects what the cache lacks itself and fails with the reason."""
    from gesturebank.app.extract import detect_people, detecting

    try:
        detect_people(job.video, detecting(config, job.range), cache=chunk_cache(out))
    except GesturebankError as exc:
        log.info("%s: chunk not detected (%s)", job.take_id, exc)


class Schedule:
    """The build's jobs in the order they may run: every chunk first (`first`), each take once
    its chunks are done (`chunk_done`), takes without chunks at once."""

    def __init__(
        self,
        jobs: list[tuple[Take, str]],
        config: Config,
        on_chunk: Callable[[str, int, int], None] | None = None,
    ) -> None:
        """on_chunk(take_id, chunks done, chunks in all): called as each chunk is done."""
        self.jobs = {take.take_id: (take, source) for take, source in jobs}
        self.chunks = {take.take_id: chunk_jobs(take, config) for take, _ in jobs}
        self.left = {take_id: len(chunks) for take_id, chunks in self.chunks.items()}
        self.on_chunk = on_chunk

    def first(self) -> list[Job]:
        chunks: list[Job] = [chunk for chunks in self.chunks.values() for chunk in chunks]
        return chunks + [job for take_id, job in self.jobs.items() if not self.left[take_id]]

    def chunk_done(self, chunk: ChunkJob) -> tuple[Take, str] | None:
        """The take that may run now that `chunk` is done (its last chunk), else None."""
        self.left[chunk.take_id] -= 1
        if self.on_chunk:
            total = len(self.chunks[chunk.take_id])
            self.on_chunk(chunk.take_id, total - self.left[chunk.take_id], total)
        return None if self.left[chunk.take_id] else self.jobs[chunk.take_id]


def content_digest(config: Config) -> str:
    return pipeline_digest(config)


def run_take(take: Take, source: str, *, out: Path, config: Config) -> TakeResult:
    """Build one take and write it; every failure becomes a `failed` record, never an exception."""
    from gesturebank.app.take import build_take

    start = time.perf_counter()
    try:
        built = build_take(take, source, config=config, chunks=chunk_cache(out))
    except GesturebankError as exc:
        reason = str(exc)
    except Exception as exc:  # a bug or a library error must not stop the other takes
        log.exception("%s: unexpected error", take.video)
        reason = f"{take.video}: unexpected {type(exc).__name__}: {exc}"
    else:
        try:
            store.write_take(out, record=built.record, clips=built.clips, preview=built.preview)
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
                built.cached,
            )
    return record_failure(
        take, source, out=out, config=config, reason=reason, wall_s=time.perf_counter() - start
    )


def record_failure(
    take: Take, source: str, *, out: Path, config: Config, reason: str, wall_s: float = 0.0
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
        store.write_take(out, record=record)
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
