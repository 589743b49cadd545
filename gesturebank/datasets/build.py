"""`build-dataset`: every take through the pipeline, in a process pool or on Ray, resumably.

Each take is built by `datasets.pipeline.build_take` (extract → repair → clips → lift → angles →
100 Hz → features → QC metrics) in a worker, which writes the take's clips and record into the
dataset folder (`datasets.store`) as soon as it is done. A take that fails anywhere is recorded
as `failed` with its one-line reason and the build goes on. When every take is done,
`datasets.refresh` judges all clips together and writes the manifest, dataset.json and the
splits; then the dashboard is written.
"""

from __future__ import annotations

import importlib
import logging
import multiprocessing
import os
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from gesturebank.config import Config
from gesturebank.datasets import store
from gesturebank.datasets.pipeline import CONTENT_SECTIONS
from gesturebank.datasets.takes import Take
from gesturebank.errors import GesturebankError, InputError

log = logging.getLogger(__name__)

Outcome = Literal["built", "skipped", "failed"]

# Imported once by the worker pool's fork server (their import is the slow part of a start).
PIPELINE_MODULES = (
    "gesturebank.datasets.pipeline",
    "gesturebank.extract.pipeline",
    "gesturebank.extract.detectors.blazepose",
    "gesturebank.extract.audio",
    "gesturebank.filters",
    "gesturebank.lift.blazepose_world",
    "gesturebank.qc.metrics",
    "gesturebank.qc.repair",
    "gesturebank.robot.retarget",
    "scipy.signal",
    "scenedetect",
)


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


@dataclass
class BuildSummary:
    out: Path
    results: list[TakeResult] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    interrupted: bool = False
    dashboard: Path | None = None
    takes: list[store.TakeRecord] = field(default_factory=list)  # final records (after QC)

    def count(self, outcome: Outcome) -> int:
        return sum(r.outcome == outcome for r in self.results)

    @property
    def failed(self) -> list[TakeResult]:
        return [r for r in self.results if r.outcome == "failed"]

    def clip_count(self, status: store.Status) -> int:
        return sum(c.qc_status == status for r in self.takes for c in r.data_clips)

    @property
    def usable_s(self) -> float:
        return sum(r.usable_s for r in self.takes)

    @property
    def visible_s(self) -> float:
        return sum(r.visible_s for r in self.takes if not r.failed)


def content_digest(config: Config) -> str:
    return config.digest(*CONTENT_SECTIONS)


def with_threads(config: Config, workers: int, cores: int) -> Config:
    """`config` with build.decode_threads and build.inference_threads resolved: as set, else
    the cores each worker has to itself (Ray tasks reserve one CPU each, so 1), so that
    workers × threads ≈ cores. On 2 cores two workers built ~4 % faster with single-threaded
    decoding, one worker ~6 % faster with frame threads.
    """
    threads = 1 if config.build.executor == "ray" else max(1, cores // workers)
    update = {
        key: threads
        for key in ("decode_threads", "inference_threads")
        if getattr(config.build, key) is None
    }
    return config.model_copy(update={"build": config.build.model_copy(update=update)})


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
        store.write_take(out, built.record, built.clips, built.preview)
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
    return _record_failure(take, source, out, config, reason, time.perf_counter() - start)


def _record_failure(
    take: Take, source: str, out: Path, config: Config, reason: str, wall_s: float = 0.0
) -> TakeResult:
    record = store.TakeRecord(
        take_id=take.take_id,
        subject=take.subject,
        source=source,
        config_digest=content_digest(config),
        failed=reason,
        detector=config.detector.name,
        lifter="multiview" if take.multi_camera else config.lifter.name,
        traits=take.traits,
    )
    store.write_take(out, record)
    return TakeResult(take.take_id, "failed", reason, wall_s)


def _local(
    jobs: list[tuple[Take, str]], out: Path, config: Config, workers: int
) -> Iterator[TakeResult]:
    if workers == 1:
        for module in PIPELINE_MODULES:  # as the pool does: start-up is not a take's time
            importlib.import_module(module)
        for take, source in jobs:
            yield run_take(take, source, out, config)
        return
    # forkserver: a clean server process (no threads inherited from mediapipe or a Ray client)
    # imports the pipeline once; every worker forks from it instead of importing for seconds.
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(list(PIPELINE_MODULES))
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        futures = {pool.submit(run_take, *job, out, config): job for job in jobs}
        pending: set[Future[TakeResult]] = set(futures)
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    try:
                        yield fut.result()
                    except BrokenProcessPool:
                        # a native crash (e.g. in a decoder) killed a worker: the pool is gone
                        reason = "worker process died; run again to resume"
                        yield _record_failure(*futures[fut], out, config, reason)
        except BaseException:
            for fut in pending:
                fut.cancel()
            raise


def _ray(
    jobs: list[tuple[Take, str]], out: Path, config: Config, address: str | None
) -> Iterator[TakeResult]:
    try:
        import ray
    except ImportError:
        raise InputError(
            "--executor ray needs Ray: pip install 'gesturebank[distributed]'"
        ) from None
    started = not ray.is_initialized()
    if started:
        ray.init(address=address, include_dashboard=False, log_to_driver=False)
    try:
        remote = ray.remote(run_take)
        pending = [remote.remote(take, source, out, config) for take, source in jobs]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])
    finally:
        if started:
            ray.shutdown()


def build_dataset(
    takes: Iterable[Take],
    videos_dir: Path,
    out: Path,
    config: Config,
    *,
    force: bool = False,
    dashboard: bool = True,
    on_result: Callable[[TakeResult], None] | None = None,
) -> BuildSummary:
    """Build (or resume) the dataset in `out`; see the module docstring."""
    from gesturebank.datasets.refresh import refresh

    out = Path(out)
    takes = list(takes)
    summary = BuildSummary(out)
    if store.remove_stale_temporaries(out):
        log.info("%s: removed temporary files of an interrupted build", out)
    digest = content_digest(config)
    jobs = []
    for take in takes:
        if not force and store.is_built(out, take.take_id, digest):
            result = TakeResult(take.take_id, "skipped")
            summary.results.append(result)
            if on_result:
                on_result(result)
        else:
            jobs.append((take, str(take.video.relative_to(videos_dir))))  # a folder: its path
    # longest first (file size as the cheap proxy), so no worker is left with a long take at the end
    jobs.sort(key=lambda job: sum(v.stat().st_size for v in job[0].videos or [job[0].video]))
    jobs.reverse()
    workers = min(config.build.workers or os.cpu_count() or 1, max(1, len(jobs)))
    config = with_threads(config, workers, os.cpu_count() or 1)
    results = (
        _ray(jobs, out, config, config.build.ray_address)
        if config.build.executor == "ray"
        else _local(jobs, out, config, workers)
    )
    try:
        for result in results:
            summary.results.append(result)
            if on_result:
                on_result(result)
    except KeyboardInterrupt:
        summary.interrupted = True  # finished takes are on disk; the manifest still covers them
    ids = [t.take_id for t in takes]
    summary.notes = refresh(out, config, take_ids=ids, videos_dir=Path(videos_dir))
    summary.takes = store.records(out, ids)
    if dashboard:
        from gesturebank.qc.dashboard import write_dashboard

        summary.dashboard = write_dashboard(out)
    return summary
