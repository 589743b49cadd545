"""One take through extraction: decode → detect (cached) → main speaker, plus the audio track.

`extract_take` is what the dataset builder calls per video. Every failure is an InputError or
DetectionError whose one-line message starts with the video's path.
"""

from __future__ import annotations

import itertools
import logging
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gesturebank.config import Config
from gesturebank.errors import DetectionError, GesturebankError, InputError
from gesturebank.extract.cache import DetectionCache, cache_key, video_digest
from gesturebank.extract.detectors import (
    DETECTORS,
    Detector,
    Frame,
    MultiPersonDetector,
    MultiPose2D,
)
from gesturebank.extract.tracking import TrackReport, main_speaker
from gesturebank.extract.video import (
    Audio,
    VideoInfo,
    first_frame_time,
    iter_frames,
    probe,
    read_audio,
)
from gesturebank.extract.video import select_indices as _select
from gesturebank.poses import Pose2D

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TakeInfo:
    """What happened to one take.

    n_frames: frames used; person_fraction: frames where anybody was found; main_fraction:
    frames where the main speaker was; cache_hit: None when the detector is not cached;
    audio_source: file the audio came from (None = no audio track).
    """

    video: VideoInfo
    detector: str
    n_frames: int
    person_fraction: float
    main_fraction: float
    tracking: TrackReport
    cache_hit: bool | None
    audio_source: str | None
    detect_seconds: float


def _frames_or_fail(path: Path, config: Config) -> Iterator[Frame]:
    """The selected frames; InputError naming the file if there are none."""
    frames = iter_frames(path, config.video, threads=config.build.decode_threads)
    first = next(frames, None)
    if first is None:
        raise InputError(f"{path}: no decodable video frames (in the selected time range)")
    return itertools.chain([first], frames)


def _detect(det: Detector, path: Path, config: Config) -> MultiPose2D:
    if not getattr(det, "needs_pixels", True) and isinstance(det, MultiPersonDetector):
        # Precomputed keypoints: the video's clock is enough, no decode.
        multi = det.detect_people(None)  # type: ignore[arg-type]
        return multi.take(_select(multi.timestamps, config.video))
    frames = _frames_or_fail(path, config)
    if isinstance(det, MultiPersonDetector):
        return det.detect_people(frames)
    return MultiPose2D.from_pose2d(det.detect(frames))


def _audio(path: Path, sample_rate: int) -> tuple[Audio | None, str | None]:
    """A `<stem>.wav` beside the video replaces its track (DESIGN.md "What a take is")."""
    wav = path.with_suffix(".wav")
    source = wav if wav.is_file() and wav != path else path
    audio = read_audio(source, sample_rate)
    if audio is not None and source == wav:
        # A separate recording is taken to start with the video's first frame.
        audio = audio._replace(start_offset_s=0.0, start_s=first_frame_time(path) or 0.0)
    return audio, (None if audio is None else str(source))


def detect_people(
    video_path: str | os.PathLike[str],
    config: Config | None = None,
    *,
    cache: DetectionCache | None = None,
    use_cache: bool = True,
    max_people: int | None = None,
) -> tuple[MultiPose2D, str, bool | None]:
    """Everybody the configured detector finds in the selected frames, through the cache.

    Returns (MultiPose2D (T, P, K, 3), detector name, cache hit — None when not cached).
    """
    config = config or Config()
    path = Path(video_path)
    try:
        factory = DETECTORS.get(config.detector.name)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    people = max_people or config.detector.max_people
    extra = {"max_people": people} if people > 1 else {}
    try:
        det = factory(config.detector, video=path, **extra)
    except GesturebankError as exc:
        raise type(exc)(f"{path}: {exc}") from None
    key = None
    store = cache or DetectionCache()
    if use_cache and getattr(det, "cacheable", True):
        params = {
            "detector": config.detector.model_dump(mode="json"),
            "video": config.video.model_dump(mode="json"),
            **extra,
        }
        key = cache_key(video_digest(path), det.name, params)
        cached = store.load(key)
        log.info("%s: detection cache %s", path, "miss" if cached is None else "hit")
        if cached is not None:
            return cached, det.name, True
    try:
        multi = _detect(det, path, config)
    except GesturebankError as exc:
        if str(path) in str(exc):
            raise
        raise type(exc)(f"{path}: {exc}") from None
    if key is not None:
        store.save(key, multi)
    return multi, det.name, None if key is None else False


def extract_take(
    video_path: str | os.PathLike[str],
    config: Config | None = None,
    *,
    cache: DetectionCache | None = None,
    use_cache: bool = True,
    max_people: int | None = None,
    with_audio: bool = True,
) -> tuple[Pose2D, Audio | None, TakeInfo]:
    """Main speaker's Pose2D (T, K, 3), the audio (or None), and a TakeInfo for one video.

    config: uses config.video (stride, range), .detector, .tracking, .audio.sample_rate.
    cache: where detections are cached (default folder when None); use_cache=False skips it.
    max_people: >1 asks a detector that supports it (mediapipe) for several people;
    None = config.detector.max_people.
    """
    config = config or Config()
    path = Path(video_path)
    info = probe(path)
    t0 = time.perf_counter()
    multi, name, hit = detect_people(
        path, config, cache=cache, use_cache=use_cache, max_people=max_people
    )
    detect_s = time.perf_counter() - t0
    if len(multi) == 0:
        raise InputError(f"{path}: no video frames to detect on")
    anybody = float(multi.present.any(axis=1).mean())
    if anybody == 0:
        raise DetectionError(f"{path}: no person detected in any of {len(multi)} frames")
    tracked = main_speaker(multi, config.tracking, source=str(path))
    if tracked.report.main_switches:
        log.warning("%s: %d identity switches", path, len(tracked.report.main_switches))
    audio, source = _audio(path, config.audio.sample_rate) if with_audio else (None, None)
    present = np.isfinite(tracked.pose.keypoints[..., 0]).any(axis=1)
    take = TakeInfo(
        video=info,
        detector=name,
        n_frames=len(multi),
        person_fraction=anybody,
        main_fraction=float(present.mean()),
        tracking=tracked.report,
        cache_hit=hit,
        audio_source=source,
        detect_seconds=detect_s,
    )
    return tracked.pose, audio, take
