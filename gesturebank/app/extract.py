"""One video through extraction: decode → detect everybody + find shot cuts (one pass, cached) →
the main speaker per shot, plus the audio track.

`extract_take` is what the dataset builder calls per video. Decoding runs in a thread that feeds a
small queue, so FFmpeg and the detector's interpreters work at the same time. Every failure is
an InputError or DetectionError whose one-line message starts with the video's path.
"""

from __future__ import annotations

import inspect
import logging
import os
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from gesturebank.audio.io import Audio, read_audio
from gesturebank.config import Config, VideoConfig
from gesturebank.errors import DetectionError, GesturebankError, InputError
from gesturebank.extract.cache import DetectionCache, cache_key, video_digest
from gesturebank.extract.chunks import Chunk, stitch, video_chunks
from gesturebank.extract.detectors import (
    DETECTORS,
    Detector,
    Frame,
    MultiPersonDetector,
)
from gesturebank.extract.face_beside import FacesBeside, faces_beside
from gesturebank.extract.face_pass import FacePass, FaceWork
from gesturebank.extract.frame_watch import watcher
from gesturebank.extract.head_pose import HeadPoses
from gesturebank.extract.shots import ShotDetector, Shots
from gesturebank.extract.tracking import Tracked, main_speaker, track_ids
from gesturebank.extract.video import (
    VideoInfo,
    first_frame_time,
    frames_at,
    iter_frames,
    prefetched,
    probe,
)
from gesturebank.extract.video import select_indices as _select
from gesturebank.poses import MultiPose2D

log = logging.getLogger(__name__)

N_PREVIEW = 4  # frames kept for the dashboard's preview strip
PREVIEW_HEIGHT = 240  # px


@dataclass(frozen=True)
class ExtractionInfo:
    """What happened to one video (a multi-camera take has one per camera).

    n_frames: frames analysed; person_fraction: frames where anybody was found; main_fraction:
    frames where the main speaker was; cache_hit: None when the detector is not cached;
    audio_source: file the audio came from (None = no audio track); mouth_seconds: time spent
    measuring mouths and heads with the face model (`extract.roles`).
    """

    video: VideoInfo
    detector: str
    n_frames: int
    person_fraction: float
    main_fraction: float
    cache_hit: bool | None
    audio_source: str | None
    detect_seconds: float
    mouth_seconds: float = 0.0


@dataclass(frozen=True)
class Detections:
    """What `detect_people` found in one video: everybody (`multi`, (T, P, K, 3)), the shot
    cuts, the detector's name, whether the detections came from the cache (None: the detector
    is not cached), and the frames decoded on the way for the preview strip — (source time,
    RGB thumbnail); none when nothing was decoded (a cache hit); the face pass, when it ran
    during detection (in its own thread, `extract.face_beside`), and the seconds the detector
    waited for it (`faces_waited_s`: its share of the detection's wall time)."""

    multi: MultiPose2D
    shots: Shots
    detector: str
    cache_hit: bool | None
    preview: tuple[tuple[float, np.ndarray], ...] = ()
    faces: FacePass | None = None  # the face pass made during detection (None: not made)
    faces_waited_s: float = 0.0


@dataclass(frozen=True)
class Extraction:
    """Everybody (`multi`), the shots, the main speaker (`tracked`), the audio, the frames
    decoded for the preview strip — (source time, RGB thumbnail) — when the video was decoded,
    and every track's head pose from the face mesh (`extract.head_pose`; None: not measured)."""

    multi: MultiPose2D
    shots: Shots
    tracked: Tracked
    audio: Audio | None
    info: ExtractionInfo
    preview: tuple[tuple[float, np.ndarray], ...] = ()
    heads: HeadPoses | None = None


class _Taps:
    """Frames on their way to the detector also feed the shot detector and the preview
    (`decoded`: in the decoding thread, off the detector's; the shot detector's downscale and
    comparison were 5-8 % of a take's time on the detector's thread), and the build's progress
    as the detector takes them (`detected`)."""

    def __init__(self, config: Config, preview_times: np.ndarray) -> None:
        self.shots = ShotDetector(config.shots)
        self.preview_times = preview_times
        self.preview: list[tuple[float, np.ndarray]] = []
        self.watch = watcher()  # the build's progress, when it watches

    def decoded(self, frames: Iterable[Frame]) -> Iterator[Frame]:
        want = list(self.preview_times)
        for t, image in frames:
            self.shots.push(t, image)
            if want and t >= want[0]:
                want.pop(0)
                self.preview.append((t, thumbnail(image)))
            yield t, image

    def detected(self, frames: Iterable[Frame]) -> Iterator[Frame]:
        for t, image in frames:
            if self.watch is not None:
                self.watch(t)
            yield t, image


def thumbnail(image: np.ndarray) -> np.ndarray:
    """`image (H, W, 3)` scaled to PREVIEW_HEIGHT px high."""
    import cv2

    h, w = image.shape[:2]
    size = (max(1, round(w * PREVIEW_HEIGHT / h)), PREVIEW_HEIGHT)
    return np.asarray(cv2.resize(image, size, interpolation=cv2.INTER_AREA))


def take_chunks(path: str, config: Config) -> list[tuple[Chunk, VideoConfig]]:
    """`extract.chunks.video_chunks` of `path` under `config`."""
    return video_chunks(path, video=config.video, build=config.build, detector=config.detector.name)


def detecting(config: Config, video: VideoConfig) -> Config:
    """`config` detecting one chunk (`video` from `video_chunks`). Chunks are always cached:
    the cache is how a chunk's task hands its people to its take's."""
    build = config.build.model_copy(update={"cache_detections": True})
    return config.model_copy(update={"video": video, "build": build})


def _create(config: Config, path: Path) -> Detector:
    try:
        factory = DETECTORS.get(config.detector.name)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    extra = {}
    if "threads" in inspect.signature(factory).parameters:  # plug-ins may not take it
        extra["threads"] = config.build.inference_threads
    try:
        return factory(config.detector.settings(), video=path, **extra)
    except GesturebankError as exc:
        raise type(exc)(f"{path}: {exc}") from None


def _face_pass(det: Detector, work: FaceWork | None) -> FacePass | None:
    """A `FacePass` fed by `det` as it detects, when it can report each frame's people."""
    skeleton = getattr(det, "skeleton", None)
    if work is None or not isinstance(det, MultiPersonDetector) or skeleton is None:
        return None
    if "on_people" not in inspect.signature(det.detect_people).parameters:
        return None
    return FacePass(work, skeleton=skeleton)


def _run(
    det: Detector, path: Path, config: Config, taps: _Taps, faces: FacesBeside | None = None
) -> tuple[MultiPose2D, Shots]:
    if not getattr(det, "needs_pixels", True) and isinstance(det, MultiPersonDetector):
        # Precomputed keypoints: the video's clock is enough, no decode (and no shot detection).
        multi = det.detect_people(None)  # type: ignore[arg-type]
        multi = multi.take(_select(multi.timestamps, config.video))
        n = len(multi)
        return multi, Shots(multi.timestamps, np.zeros(0), np.full(n, np.nan, np.float32))
    decoded = iter_frames(path, config.video, threads=config.build.decode_threads)
    # the shots and the preview are read once the stream has ended, when the thread has too
    frames = prefetched(taps.decoded(decoded))
    first = next(frames, None)
    if first is None:
        raise InputError(f"{path}: no decodable video frames (in the selected time range)")

    def all_frames() -> Iterator[Frame]:
        yield first
        yield from frames

    stream = taps.detected(all_frames())
    if isinstance(det, MultiPersonDetector):
        # on_people: only passed to a detector whose signature has it (`_face_pass`)
        extra = {} if faces is None else {"on_people": faces}
        multi = det.detect_people(stream, **extra)
    else:
        multi = MultiPose2D.from_pose2d(det.detect(stream))
    return multi, taps.shots.result()


def detect_people(
    video_path: str | os.PathLike[str],
    config: Config | None = None,
    *,
    cache: DetectionCache | None = None,
    preview_times: np.ndarray | None = None,
    faces: FaceWork | None = None,
) -> Detections:
    """Everybody the configured detector finds in the selected frames, and the shot cuts,
    through the cache (config.build.cache_detections); the preview frames are the ones decoded
    on the way at `preview_times`; with `faces`, the face pass run on the frames as they are
    detected (when the detector reports each frame's people and nothing came from the cache).
    """
    config = config or Config()
    path = Path(video_path)
    det = _create(config, path)
    taps = _Taps(config, np.asarray(preview_times if preview_times is not None else []))
    key = None
    store = cache or DetectionCache()
    if config.build.cache_detections and getattr(det, "cacheable", True):
        own = config.detector.settings()  # the chosen detector's settings, not the others'
        params: dict[str, Any] = {"detector": None if own is None else own.model_dump(mode="json")}
        params["video"] = config.video.model_dump(mode="json")
        params["shots"] = config.shots.model_dump(mode="json")
        # a detector's `version` changes when its code gives other output for the same video
        params["version"] = getattr(det, "version", 0)
        key = cache_key(video_digest(path), det.name, params=params)
        cached = store.load(key)
        log.info("%s: detection cache %s", path, "miss" if cached is None else "hit")
        if cached is not None:
            return Detections(cached[0], cached[1], det.name, True)
    face_pass = _face_pass(det, faces)
    try:
        # the face pass of frame n beside the pose pass of frame n + 1 (`extract.face_beside`)
        with faces_beside(face_pass) as beside:
            multi, shots = _run(det, path, config, taps, beside)
    except GesturebankError as exc:
        if str(path) in str(exc):
            raise
        raise type(exc)(f"{path}: {exc}") from None
    if key is not None:
        try:
            store.save(key, multi, shots)
        except OSError as exc:  # e.g. a full disk: the cache only saves time, the take goes on
            log.warning("%s: detection cache not written (%s)", path, exc.strerror or exc)
    hit = None if key is None else False
    waited = 0.0 if beside is None else beside.waited_s
    return Detections(multi, shots, det.name, hit, tuple(taps.preview), face_pass, waited)


def _detect_chunks(
    path: Path, config: Config, plan: list[tuple[Chunk, VideoConfig]], chunks: DetectionCache
) -> Detections:
    """`detect_people` of a long video, chunk by chunk through `chunks` (what the build's chunk
    tasks left there is read, the rest detected), stitched. A cache hit: every chunk was
    cached. No preview frames."""
    parts, hits, name = [], [], ""
    for chunk, video in plan:
        found = detect_people(path, detecting(config, video), cache=chunks)
        name = found.detector
        parts.append((chunk, found.multi, found.shots))
        hits.append(bool(found.cache_hit))
    multi, shots = stitch(parts=parts)
    return Detections(multi, shots, name, all(hits))


def preview_times(info: VideoInfo, *, config: Config, n: int = N_PREVIEW) -> np.ndarray:
    """`n` source times spread over the used range of the video (for the preview strip)."""
    end = config.video.end_s if config.video.end_s is not None else info.duration_s
    if not np.isfinite(end):
        return np.zeros(0)
    start = config.video.start_s
    return start + (end - start) * (np.arange(n) + 0.5) / n


def _audio(path: Path, sample_rate: int) -> tuple[Audio | None, str | None]:
    """A `<stem>.wav` beside the video replaces its track
    (docs/architecture.md "What a take is")."""
    wav = path.with_suffix(".wav")
    source = wav if wav.is_file() and wav != path else path
    audio = read_audio(source, sample_rate=sample_rate)
    if audio is not None and source == wav:
        # A separate recording is taken to start with the video's first frame.
        audio = audio._replace(start_offset_s=0.0, start_s=first_frame_time(path) or 0.0)
    return audio, (None if audio is None else str(source))


def face_work(config: Config) -> FaceWork | None:
    """What the face pass measures under `config` (None: nothing, no face model)."""
    r = config.retarget
    want_heads = r.head_source == "face"
    if not (config.speech.mouths or want_heads):
        return None
    return FaceWork(
        config.speech,
        config.speech.mouths,
        (r.head_max_face_turn, r.head_min_face_px) if want_heads else None,
        mouth_alone=config.speech.mouths_alone,
    )


def _who_speaks(
    path: Path,
    multi: MultiPose2D,
    shots: Shots,
    audio: Audio | None,
    config: Config,
    found: FacePass | None = None,
) -> tuple[Tracked, HeadPoses | None, float]:
    """The main speaker per shot, with everybody's roles when speech.mouths is on, or the
    person a `<stem>.people.toml` names; everybody's head from the same face-model runs
    (retarget.head_source = "face"); and the seconds the faces took. found: the face pass made
    during detection (None: a second, cheaper decode at speech.mouth_rate_hz makes it)."""
    from gesturebank.extract.people_file import chosen_track, read_people_file
    from gesturebank.extract.roles import measure_people

    ids = track_ids(multi, config.tracking, cuts=shots.cuts)
    spec = read_people_file(path)
    keep = None if spec is None else chosen_track(spec, multi=multi, ids=ids)
    roles, heads, mouth_s = None, None, 0.0
    work = face_work(config)
    if work is not None and (ids >= 0).any():
        t0 = time.perf_counter()
        roles, heads = measure_people(
            video=path,
            multi=multi,
            ids=ids,
            audio=audio,
            video_config=config.video,
            config=config.speech,
            threads=config.build.decode_threads,
            mouths=work.mouths,
            head_limits=work.head_limits,
            mouth_alone=work.mouth_alone,
            found=found,
        )
        heads = heads if work.head_limits is not None else None
        mouth_s = time.perf_counter() - t0 + (found.seconds if found is not None else 0.0)
    tracked = main_speaker(
        multi,
        config.tracking,
        cuts=shots.cuts,
        audio=audio,
        source=str(path),
        ids=ids,
        roles=roles,
        speech=config.speech,
        keep=keep,
    )
    return tracked, heads, mouth_s


def extract_take(
    video_path: str | os.PathLike[str],
    config: Config | None = None,
    *,
    cache: DetectionCache | None = None,
    chunks: DetectionCache | None = None,
    with_audio: bool = True,
) -> Extraction:
    """Everybody, the shots, the main speaker per shot, and the audio (or None) of one video.

    config: uses config.video (range, stride, max_fps), .detector, .shots, .tracking,
    .audio.sample_rate, .build (threads, cache, chunks). cache: where detections are cached
    (default folder when None). chunks: where a video longer than build.chunk_s finds (or
    leaves) its chunks' detections (`extract.chunks`); None: detected in one pass.
    """
    config = config or Config()
    path = Path(video_path)
    info = probe(path)
    t0 = time.perf_counter()
    times = preview_times(info, config=config)
    plan = [] if chunks is None else take_chunks(str(path), config)
    if chunks is not None and plan:
        found = _detect_chunks(path, config, plan, chunks)
    else:
        found = detect_people(
            path, config, cache=cache, preview_times=times, faces=face_work(config)
        )
    multi, shots, preview = found.multi, found.shots, list(found.preview)
    # the face pass made during detection ran beside it: the time the detector waited for it is
    # the faces' time, not the detector's (where its CPU slowed the detector, that is counted
    # in the detector's time: the two cannot be told apart on the clock)
    detect_s = time.perf_counter() - t0 - found.faces_waited_s
    if not preview and len(times):  # detections from the cache: the frames were not decoded
        preview = [(t, thumbnail(image)) for t, image in frames_at(path, times.tolist())]
    if len(multi) == 0:
        raise InputError(f"{path}: no video frames to detect on")
    anybody = float(multi.present.any(axis=1).mean())
    if anybody == 0:
        raise DetectionError(f"{path}: no person detected in any of {len(multi)} frames")
    audio, source = _audio(path, config.audio.sample_rate) if with_audio else (None, None)
    tracked, heads, mouth_s = _who_speaks(path, multi, shots, audio, config, found.faces)
    if tracked.report.main_switches:
        log.warning("%s: %d identity switches", path, len(tracked.report.main_switches))
    present = np.isfinite(tracked.pose.keypoints[..., 0]).any(axis=1)
    summary = ExtractionInfo(
        video=info,
        detector=found.detector,
        n_frames=len(multi),
        person_fraction=anybody,
        main_fraction=float(present.mean()),
        cache_hit=found.cache_hit,
        audio_source=source,
        detect_seconds=detect_s,
        mouth_seconds=mouth_s,
    )
    return Extraction(multi, shots, tracked, audio, summary, tuple(preview), heads)
