"""`build-dataset`: every take through the pipeline, in a process pool or on Ray, resumably.

Each take is built by `app.take.build_take` (extract → repair → clips → lift → angles →
100 Hz → features → QC metrics) in a worker, which writes the take's clips and record into the
dataset folder (`datasets.store`) as soon as it is done. A take that fails anywhere is recorded
as `failed` with its one-line reason and the build goes on. When every take is done,
`datasets.refresh` judges all clips together and writes the manifest, dataset.json and the
splits. The QC dashboard (`report`) is written by the caller: the CLI, after the build.

One build at a time holds OUT_DIR's lock (`datasets.lock`); pool workers die with the build
(`datasets.lifeline`); SIGTERM stops it as Ctrl-C does. A take that cannot be written (a full
disk) fails alone, with nothing of it under a final name.
"""

from __future__ import annotations

import importlib
import logging
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable, Generator, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import closing, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gesturebank.app.frame_board import POLL_S, FrameBoard, start_worker, watched
from gesturebank.app.take_job import (
    ChunkJob,
    Job,
    Outcome,
    Schedule,
    TakeResult,
    content_digest,
    record_failure,
    record_stamp,
    run_chunk,
    run_take,
    written_result,
)
from gesturebank.config import Config
from gesturebank.datasets import store
from gesturebank.datasets.lock import dataset_lock
from gesturebank.datasets.takes import Take
from gesturebank.errors import InputError
from gesturebank.extract.frame_watch import watching

log = logging.getLogger(__name__)

_DIED = "worker process died; run again to resume"
FramesCallback = Callable[[str, float], None]  # take id, seconds of its video detected

# Imported once by the worker pool's fork server (their import is the slow part of a start).
PIPELINE_MODULES = (
    "gesturebank.app.take",
    "gesturebank.app.extract",
    "gesturebank.extract.detectors.blazepose",
    "gesturebank.audio.features",
    "gesturebank.filters",
    "gesturebank.lift.blazepose_world",
    "gesturebank.qc.metrics",
    "gesturebank.repair",
    "gesturebank.robot.retarget",
    "scipy.signal",
    "scenedetect",
)


@dataclass
class BuildSummary:
    out: Path
    results: list[TakeResult] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    interrupted: int = 0  # the signal that stopped the build (SIGINT, SIGTERM); 0: it ran through
    error: str = ""  # one line when the dataset's shared files could not be written (full disk)
    dashboard: Path | None = None  # the QC dashboard's index, when the caller wrote it
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


def cannot_write(out: Path, exc: OSError) -> str:
    """The one line a build ends with when a file shared by the whole dataset (the manifest,
    dataset.json, the dashboard) cannot be written."""
    return (
        f"{exc.filename or out}: cannot write ({exc.strerror or exc}); finished takes are "
        "kept: free some space and run the same command again"
    )


def with_threads(config: Config, *, workers: int, cores: int) -> Config:
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


def _local(
    schedule: Schedule,
    out: Path,
    config: Config,
    workers: int,
    on_frames: FramesCallback | None = None,
) -> Generator[TakeResult, None, None]:
    if workers == 1:
        for module in PIPELINE_MODULES:  # as the pool does: start-up is not a take's time
            importlib.import_module(module)
        for take, source in schedule.jobs.values():  # each detects its chunks itself
            with _every_poll(take.take_id, config.video.start_s, on_frames):
                result = run_take(take, source, out=out, config=config)
            yield result
        return
    # forkserver: a clean server process (no threads inherited from mediapipe or a Ray client)
    # imports the pipeline once; every worker forks from it instead of importing for seconds.
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(list(PIPELINE_MODULES))
    board = FrameBoard(ctx, len(schedule.first()) + len(schedule.jobs))
    with ProcessPoolExecutor(
        max_workers=workers,
        mp_context=ctx,
        initializer=start_worker,
        initargs=(os.getpid(), board.values),
    ) as pool:
        jobs: dict[Future[Any], Job] = {}  # TakeResult of a take, None of a chunk
        died: list[TakeResult] = []  # takes that could not be queued: the pool is gone

        def submit(job: Job) -> set[Future[Any]]:
            try:
                fut: Future[Any] = (
                    pool.submit(
                        watched,
                        board.claim(job.take_id, job.own_s),
                        run_chunk,
                        job,
                        out=out,
                        config=config,
                    )
                    if isinstance(job, ChunkJob)
                    else pool.submit(
                        watched,
                        board.claim(job[0].take_id, config.video.start_s),
                        run_take,
                        *job,
                        out=out,
                        config=config,
                    )
                )
            except BrokenProcessPool:
                take = schedule.jobs[job.take_id] if isinstance(job, ChunkJob) else job
                died.append(record_failure(*take, out=out, config=config, reason=_DIED))
                return set()
            jobs[fut] = job
            return {fut}

        pending = {fut for job in schedule.first() for fut in submit(job)}
        try:
            while pending or died:
                yield from died
                died.clear()
                if not pending:
                    break
                done, pending = wait(pending, timeout=POLL_S, return_when=FIRST_COMPLETED)
                if on_frames is not None:
                    for take_id, seconds in board.seconds().items():
                        on_frames(take_id, seconds)
                for fut in done:
                    job = jobs[fut]
                    if isinstance(job, ChunkJob):
                        # a chunk that failed (even its worker) is detected by its take's task
                        ready = schedule.chunk_done(job)
                        if ready is not None:
                            pending |= submit(ready)
                        continue
                    try:
                        result = fut.result()
                    except BrokenProcessPool:
                        # a native crash (e.g. in a decoder) killed a worker: the pool is gone
                        yield record_failure(*job, out=out, config=config, reason=_DIED)
                        continue
                    assert result is not None
                    yield result
        except BaseException:
            for fut in pending:
                fut.cancel()
            # takes already queued cannot be cancelled, and running ones would go on writing
            # into OUT_DIR after an interrupt: stop the workers (no public API before 3.14)
            for process in list(pool._processes.values()):
                process.terminate()
            raise


@contextmanager
def _every_poll(take_id: str, start_s: float, on_frames: FramesCallback | None) -> Iterator[None]:
    """Inside (a take built in this process), `on_frames` with the take's seconds of video
    detected, at most every `POLL_S` (the frame loop itself only compares two clocks)."""
    if on_frames is None:
        yield
        return
    last = [-POLL_S]

    def seen(t: float) -> None:
        now = time.monotonic()
        if now - last[0] >= POLL_S:
            last[0] = now
            on_frames(take_id, max(0.0, t - start_s))

    with watching(seen):
        yield


def _ray(
    schedule: Schedule, out: Path, videos_dir: Path, config: Config
) -> Generator[TakeResult, None, None]:
    from gesturebank.app.cluster import run_on_ray  # needs Ray: imported when used

    yield from run_on_ray(
        schedule, out=out, videos_dir=videos_dir, config=config
    )  # close() reaches it: tasks cancelled


@contextmanager
def _sigterm_interrupts() -> Iterator[list[int]]:
    """Inside, SIGTERM raises KeyboardInterrupt, as SIGINT does: the build stops as on Ctrl-C.
    Yields the list of the SIGTERMs received (Ray turns any signal's exception into its own)."""
    received: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield received  # only the main thread may set handlers (and receives the signals)
        return

    def stop(signum: int, frame: object) -> None:
        received.append(signum)
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        yield received
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


def build_dataset(
    takes: Iterable[Take],
    *,
    videos_dir: Path,
    out: Path,
    config: Config,
    force: bool = False,
    on_result: Callable[[TakeResult], None] | None = None,
    on_chunk: Callable[[str, int, int], None] | None = None,
    on_frames: FramesCallback | None = None,
) -> BuildSummary:
    """Build (or resume) the dataset in `out`; see the module docstring. on_result(result): as
    each take ends; on_chunk(take_id, done, total): as each chunk of a long video is detected;
    on_frames(take_id, seconds): how much of a take's video is detected, every `POLL_S` while it
    is (the local executor only: Ray reports chunks and takes).

    Holds the dataset's lock throughout (InputError naming the holder when another build or
    `gesturebank qc` writes `out`). SIGTERM and Ctrl-C stop it the same way: the workers are
    stopped, finished takes are kept and counted, the manifest covers them.
    """
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{out}: cannot create the dataset folder ({exc.strerror})") from None
    with dataset_lock(out):
        return _build(
            list(takes),
            Path(videos_dir),
            out,
            config,
            force=force,
            on_result=on_result,
            on_chunk=on_chunk,
            on_frames=on_frames,
        )


def _build(
    takes: list[Take],
    videos_dir: Path,
    out: Path,
    config: Config,
    *,
    force: bool,
    on_result: Callable[[TakeResult], None] | None,
    on_chunk: Callable[[str, int, int], None] | None,
    on_frames: FramesCallback | None,
) -> BuildSummary:
    from gesturebank.datasets.card import read_takes_toml
    from gesturebank.datasets.refresh import refresh

    summary = BuildSummary(out)
    read_takes_toml(videos_dir)  # a bad takes.toml stops the build before any take, not after
    if store.remove_stale_temporaries(out):
        log.info("%s: removed temporary files of an interrupted build", out)
    digest = content_digest(config)
    jobs = []
    for take in takes:
        if not force and store.is_built(out, take_id=take.take_id, config_digest=digest):
            result = TakeResult(take.take_id, "skipped")
            summary.results.append(result)
            if on_result:
                on_result(result)
        else:
            jobs.append((take, str(take.video.relative_to(videos_dir))))  # a folder: its path
    # longest first (file size as the cheap proxy), so no worker is left with a long take at the end
    jobs.sort(key=lambda job: sum(v.stat().st_size for v in job[0].videos or [job[0].video]))
    jobs.reverse()
    schedule = Schedule(jobs, config, on_chunk)
    workers = min(config.build.workers or os.cpu_count() or 1, max(1, len(schedule.first())))
    config = with_threads(config, workers=workers, cores=os.cpu_count() or 1)
    results = (
        _ray(schedule, out, videos_dir, config)
        if config.build.executor == "ray"
        else _local(schedule, out, config, workers, on_frames)
    )
    stamps = {take.take_id: record_stamp(out, take.take_id) for take, _ in jobs}
    terms: list[int] = []
    try:
        # closing: an interrupt stops the workers here, not whenever the generator is collected
        with _sigterm_interrupts() as terms, closing(results):
            for result in results:
                summary.results.append(result)
                if on_result:
                    on_result(result)
    except KeyboardInterrupt:
        summary.interrupted = signal.SIGTERM if terms else signal.SIGINT
        store.remove_stale_temporaries(out)  # what the stopped workers left half-written
        reported = {r.take_id for r in summary.results}
        for take, _ in jobs:
            if take.take_id in reported or record_stamp(out, take.take_id) == stamps[take.take_id]:
                continue
            written = written_result(out, take.take_id)
            if written:
                summary.results.append(written)
                if on_result:
                    on_result(written)
    ids = [t.take_id for t in takes]
    try:
        summary.notes = refresh(out, config, take_ids=ids, videos_dir=videos_dir)
    except OSError as exc:  # a full disk: the finished takes are kept, a re-run completes it
        summary.error = cannot_write(out, exc)
    summary.takes = store.take_records(out, ids)
    return summary


def dashboard_after_build(summary: BuildSummary) -> BuildSummary:
    """`summary` of a finished `build-dataset`, with its dataset's dashboard written
    (`summary.dashboard`) under the dataset's lock, or with the one line why it could not be
    (`summary.error`). Nothing is written when the build could not write the shared files."""
    from gesturebank.report import write_dashboard

    if summary.error:
        return summary
    with dataset_lock(summary.out):
        try:
            summary.dashboard = write_dashboard(summary.out)
        except OSError as exc:  # a full disk: the finished takes are kept, a re-run completes it
            summary.error = cannot_write(summary.out, exc)
    return summary
