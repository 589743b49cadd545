"""`build-dataset`: every take through the pipeline, in a process pool or on Ray, resumably.

One take (DESIGN.md "Data flow"): extract (decode, detect — cached —, main speaker, audio) →
lift → Pepper angles at the video's timestamps → onto the 100 Hz audio frame clock → zero-phase
Butterworth → clamp to the robot's limits → normalise to [0, 1]; audio features on the same
clock; both trimmed to their common span. A take that fails anywhere is recorded as `failed`
with its one-line reason and the build goes on.
"""

from __future__ import annotations

import importlib
import logging
import math
import multiprocessing
import os
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from gesturebank import __version__
from gesturebank.config import Config
from gesturebank.datasets import store
from gesturebank.datasets.splits import write_splits
from gesturebank.datasets.takes import Take
from gesturebank.errors import GesturebankError, InputError

if TYPE_CHECKING:
    from gesturebank.extract.pipeline import TakeInfo
    from gesturebank.extract.video import Audio
    from gesturebank.poses import Pose2D, Pose3D

log = logging.getLogger(__name__)

Outcome = Literal["built", "skipped", "failed"]

# Imported once by the worker pool's fork server (their import is the slow part of a start).
PIPELINE_MODULES = (
    "gesturebank.extract.pipeline",
    "gesturebank.extract.detectors.mediapipe",
    "gesturebank.extract.audio",
    "gesturebank.filters",
    "gesturebank.lift.blazepose_world",
    "gesturebank.robot.retarget",
    "mediapipe.python.solutions.pose",
    "scipy.signal",
)

# Config sections that change what a take contains (the build section only changes how).
CONTENT_SECTIONS = ("video", "detector", "tracking", "lifter", "robot", "processing", "audio")


@dataclass(frozen=True)
class TakeResult:
    take_id: str
    outcome: Outcome
    reason: str = ""
    wall_s: float = 0.0
    video_s: float = 0.0
    detect_s: float = 0.0


@dataclass
class BuildSummary:
    out: Path
    results: list[TakeResult] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    interrupted: bool = False
    dashboard: Path | None = None
    qc: dict[str, tuple[str, list[str]]] = field(default_factory=dict)  # take → (status, reasons)

    def count(self, outcome: Outcome) -> int:
        return sum(r.outcome == outcome for r in self.results)

    @property
    def failed(self) -> list[TakeResult]:
        return [r for r in self.results if r.outcome == "failed"]


def content_digest(config: Config) -> str:
    return config.digest(*CONTENT_SECTIONS)


def audio_clock(
    pose_t: np.ndarray, audio_start_s: float, n_frames: int, hop_s: float, win_s: float
) -> tuple[int, int, np.ndarray]:
    """Audio frames whose window centre lies within the pose's time span.

    Frame i covers [start + i·hop, start + i·hop + win) (extract.audio), so its centre is at
    start + i·hop + win/2. Returns (i0, i1, times (i1 − i0 + 1,)) — the common span of audio and
    video on the audio frame clock; InputError when they do not overlap.
    """
    c0 = audio_start_s + win_s / 2
    eps = 1e-9  # timestamps that land on a frame centre up to float rounding count as inside
    i0 = max(0, math.ceil((pose_t[0] - c0) / hop_s - eps))
    i1 = min(n_frames - 1, math.floor((pose_t[-1] - c0) / hop_s + eps))
    if i1 < i0:
        raise InputError("audio and video do not overlap in time")
    return i0, i1, c0 + hop_s * np.arange(i0, i1 + 1)


def process_take(take: Take, config: Config) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Arrays of one take (DESIGN.md "Dataset on disk") and its metrics; raises on failure."""
    from gesturebank.extract.audio import features
    from gesturebank.extract.pipeline import extract_take
    from gesturebank.filters import butter_lowpass, resample_to_clock
    from gesturebank.lift import LIFTERS
    from gesturebank.robot import pepper
    from gesturebank.robot.retarget import pepper_angles

    audio: Audio | None
    if take.multi_camera:
        pose2d, pose3d, audio, info = _lift_cameras(take, config)
    else:
        if config.lifter.name == "multiview":
            raise InputError(
                f"{take.video}: the multiview lifter needs a multi-camera take (a folder with a "
                "calibration file and two or more videos)"
            )
        pose2d, audio, info = extract_take(
            take.video, config, use_cache=config.build.cache_detections
        )
        if audio is None:
            raise InputError(f"{take.video}: no audio track and no {take.video.stem}.wav beside it")
        pose3d = LIFTERS.create(config.lifter.name, config).lift(pose2d)
    raw = pepper_angles(pose3d)  # (T, 11) at the video's own timestamps

    a = config.audio
    feats = features(audio.signal, audio.sample_rate, a)
    i0, i1, times = audio_clock(
        pose3d.timestamps, audio.start_s, len(feats), a.winstep_s, a.winlen_s
    )

    p = config.processing
    _, angles, gaps = resample_to_clock(
        raw,
        pose3d.timestamps,
        p.rate_hz,
        t0=float(times[0]),
        t1=float(times[-1]),
        max_gap_s=p.max_gap_s,
    )
    angles = angles[: len(times)]
    smooth = butter_lowpass(angles, p.rate_hz, p.cutoff_hz, p.butter_order)
    profile = pepper.load_profile(config.robot.profile)
    clamped = pepper.clamp(smooth, profile)
    finite = np.isfinite(smooth)
    at_limit = finite & ((smooth <= profile.lower) | (smooth >= profile.upper))

    arrays = {
        "angles": clamped.astype(np.float32),
        "angles01": pepper.normalise(clamped, profile).astype(np.float32),
        "audio": feats[i0 : i1 + 1].astype(np.float32),
        "times": times,
        "raw_angles": raw.astype(np.float32),
        "timestamps": pose3d.timestamps,
        **pose2d.to_arrays("pose2d_"),
        **pose3d.to_arrays("pose3d_"),
    }
    duration = float(times[-1] - times[0]) + 1 / p.rate_hz
    metrics = {
        "duration_s": duration,
        "video_fps": info.video.fps,
        "detect_s": info.detect_seconds,
        "person_fraction": info.person_fraction,
        "main_fraction": info.main_fraction,
        "identity_switches": float(len(info.tracking.main_switches)),
        "missing_fraction": gaps.missing_fraction,
        "longest_gap_s": gaps.longest_gap_s,
        "clamped_fraction": float(at_limit.sum() / max(1, finite.sum())),
        "audio_trimmed_s": (i0 + len(feats) - 1 - i1) * a.winstep_s,
        "video_trimmed_s": float(times[0] - pose3d.timestamps[0])
        + float(pose3d.timestamps[-1] - times[-1]),
    }
    lifter = "multiview" if take.multi_camera else config.lifter.name
    extra = {
        "metrics": metrics,
        "detector": info.detector,
        "lifter": lifter,
        "n_frames": len(times),
    }
    return arrays, extra


def _lift_cameras(take: Take, config: Config) -> tuple[Pose2D, Pose3D, Audio, TakeInfo]:
    """A multi-camera take: every camera detected, triangulated by the multi-view lifter.

    The reference camera's 2D pose and clock stand for the take. The audio is a .wav beside the
    videos, else the camera track with the most energy, moved onto the reference clock by the
    camera offsets the lifter used.
    """
    from gesturebank.extract.pipeline import extract_take
    from gesturebank.extract.video import read_audio
    from gesturebank.lift.multiview.cameras import CameraGroup
    from gesturebank.lift.multiview.lifter import MultiviewLifter, match_videos

    assert take.calibration is not None
    cameras = CameraGroup.load(take.calibration)
    videos = match_videos(cameras, take.videos)
    extracted = [extract_take(v, config, use_cache=config.build.cache_detections) for v in videos]
    poses = [pose for pose, _, _ in extracted]
    audios = [audio for _, audio, _ in extracted]
    pose3d, report = MultiviewLifter(config, cameras=cameras).lift_with_report(poses, audios=audios)
    ref = config.multiview.reference_camera
    if take.audio is not None:
        audio = read_audio(take.audio, config.audio.sample_rate)
        if audio is None:
            raise InputError(f"{take.audio}: no audio in this file")
        audio = audio._replace(start_s=float(poses[ref].timestamps[0]))  # recorded with the video
    else:
        tracks = [(c, a) for c, a in enumerate(audios) if a is not None and len(a.signal)]
        if not tracks:
            raise InputError(
                f"{take.video}: no camera has an audio track and no .wav is beside them"
            )
        c, best = max(tracks, key=lambda ca: float(np.mean(np.square(ca[1].signal))))
        audio = best._replace(start_s=best.start_s - float(report.offsets_s[c]))
    return poses[ref], pose3d, audio, extracted[ref][2]


def with_decode_threads(config: Config, workers: int, cores: int) -> Config:
    """`config` with build.decode_threads resolved: as set, else the cores each worker has to
    itself (Ray tasks reserve one CPU each, so 1). On 2 cores two workers build ~4 % faster
    with single-threaded decoding, one worker ~6 % faster with frame threads.
    """
    if config.build.decode_threads is not None:
        return config
    threads = 1 if config.build.executor == "ray" else max(1, cores // workers)
    return config.model_copy(
        update={"build": config.build.model_copy(update={"decode_threads": threads})}
    )


def run_take(take: Take, source: str, out: Path, config: Config) -> TakeResult:
    """Build one take and write it; every failure becomes a `failed` record, never an exception."""
    start = time.perf_counter()
    digest = content_digest(config)
    base: dict[str, Any] = {
        "take_id": take.take_id,
        "subject": take.subject,
        "source": source,
        "config_digest": digest,
        "traits": take.traits,
    }
    try:
        arrays, extra = process_take(take, config)
    except GesturebankError as exc:
        reason = str(exc)
    except Exception as exc:  # a bug or a library error must not stop the other takes
        log.exception("%s: unexpected error", take.video)
        reason = f"{take.video}: unexpected {type(exc).__name__}: {exc}"
    else:
        metrics = extra["metrics"]
        record = store.TakeRecord(
            qc_status="accepted",
            duration_s=metrics["duration_s"],
            video_fps=metrics["video_fps"],
            detector=extra["detector"],
            lifter=extra["lifter"],
            metrics=metrics,
            n_frames=extra["n_frames"],
            **base,
        )
        store.write_take(out, record, arrays)
        wall = time.perf_counter() - start
        return TakeResult(
            take.take_id, "built", "", wall, metrics["duration_s"], metrics["detect_s"]
        )
    return _record_failure(take, source, out, config, reason, time.perf_counter() - start)


def _record_failure(
    take: Take, source: str, out: Path, config: Config, reason: str, wall_s: float = 0.0
) -> TakeResult:
    record = store.TakeRecord(
        take_id=take.take_id,
        subject=take.subject,
        source=source,
        qc_status="failed",
        qc_reasons=(reason,),
        config_digest=content_digest(config),
        detector=config.detector.name,
        lifter="multiview" if take.multi_camera else config.lifter.name,
        traits=take.traits,
    )
    store.write_take(out, record, None)
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


def finalise(out: Path, config: Config, take_ids: list[str], videos_dir: Path) -> list[str]:
    """QC verdicts over all takes together, then manifest.parquet, dataset.json (with audio
    normalisation stats of every built take's subject) and splits. Returns notes."""
    from gesturebank.extract.audio import feature_dim, fit_znorm
    from gesturebank.qc.checks import apply_verdicts
    from gesturebank.robot import pepper

    apply_verdicts(out, config.qc, take_ids)  # dataset-relative: always over every take
    table = store.write_manifest(out, take_ids)
    rows = table.to_pylist()
    by_subject: dict[str, list[np.ndarray]] = {}
    for row in rows:
        if row["qc_status"] != "failed":  # a rejected take's motion is bad, its audio is not
            with np.load(store.take_npz(out, row["take_id"]), allow_pickle=False) as data:
                by_subject.setdefault(row["subject"], []).append(data["audio"])
    stats: dict[str, Any] = {}
    for subject, feats in sorted(by_subject.items()):
        mean, std = fit_znorm(feats)
        stats[subject] = {"mean": mean.tolist(), "std": std.tolist()}
    if by_subject:
        mean, std = fit_znorm([f for fs in by_subject.values() for f in fs])
        stats["*"] = {"mean": mean.tolist(), "std": std.tolist()}
    profile = pepper.load_profile(config.robot.profile)
    store.write_dataset_json(
        out,
        {
            "tool": "gesturebank",
            "tool_version": __version__,
            "videos_dir": str(Path(videos_dir).resolve()),
            "config": config.to_json_dict(),
            "config_digest": content_digest(config),
            "joints": list(pepper.JOINTS),
            "limits": profile.as_dict(),
            "robot_profile": profile.name,
            "rates": {"pose_hz": config.processing.rate_hz, "audio_hz": 1 / config.audio.winstep_s},
            "audio_features": {
                "kind": config.audio.features,
                "dim": feature_dim(config.audio),
                "params": config.audio.model_dump(),
                "frame_time": "window centre: start + i·winstep_s + winlen_s / 2",
            },
            "normalisation": {"audio_znorm_by_subject": stats},
            "takes": {s: sum(r["qc_status"] == s for r in rows) for s in store.STATUSES},
        },
    )
    return write_splits(out, rows, config.splits)


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
    config = with_decode_threads(config, workers, os.cpu_count() or 1)
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
    summary.notes = finalise(out, config, [t.take_id for t in takes], videos_dir)
    for row in store.Dataset(out).records():
        summary.qc[row["take_id"]] = (row["qc_status"], row["qc_reasons"])
    if dashboard:
        from gesturebank.qc.dashboard import write_dashboard

        summary.dashboard = write_dashboard(out, config.qc, config.build.workers)
    return summary
