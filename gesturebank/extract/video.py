"""Video decoding with PyAV: frames with their real timestamps (the audio track: `audio_io`).

Timestamps are the presentation timestamps of the stream (pts × time_base, seconds), never
index / fps: phone videos often have a variable frame rate. Frames are streamed one at a time.
Every failure to read a file is an `InputError` whose one-line message names the file.
"""

from __future__ import annotations

import logging
import os
import queue
import threading
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import av
import numpy as np
from av.video.reformatter import VideoReformatter

from gesturebank.config import VideoConfig
from gesturebank.errors import InputError

log = logging.getLogger(__name__)

PathLike = str | os.PathLike[str]
# Decoded frames queued ahead of their consumer: at most PREFETCH, and at most PREFETCH_BYTES
# of them (but 2), so a 4K UHD video (25 MB a frame) queues 2, not 200 MB per worker.
PREFETCH = 8
PREFETCH_BYTES = 64 * 2**20


@dataclass(frozen=True)
class VideoInfo:
    """What `probe` learns from the container headers (no full decode).

    size is (width, height) after the rotation metadata is applied; fps is the container's
    average rate (an estimate: the real clock is the per-frame timestamps); n_frames is None
    when the container does not say.
    """

    path: str
    duration_s: float
    fps: float
    n_frames: int | None
    size: tuple[int, int]
    rotation: int
    codec: str
    has_audio: bool
    audio_codec: str | None = None


def open_media(path: PathLike) -> av.container.InputContainer:
    """The file opened for reading; a missing or unreadable one is an InputError naming it."""
    name = os.fspath(path)
    if not Path(name).is_file():
        raise InputError(f"{name}: no such file")
    try:
        return av.open(name, mode="r")
    except (av.FFmpegError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"{name}: not a readable media file ({av_reason(exc)})") from None


def av_reason(exc: BaseException) -> str:
    """FFmpeg's own words without the file name (the message names the file once)."""
    text = getattr(exc, "strerror", None) or str(exc)
    return " ".join(str(text).split()) or type(exc).__name__


def _video_stream(container: av.container.InputContainer, name: str) -> av.video.stream.VideoStream:
    if not container.streams.video:
        raise InputError(f"{name}: no video stream")
    return container.streams.video[0]


def _rotation(stream: av.video.stream.VideoStream, container: av.container.InputContainer) -> int:
    """Display rotation in degrees counter-clockwise (0, 90, 180, 270), from the first frame's
    display matrix (FFmpeg copies the stream's matrix onto every decoded frame)."""
    try:
        frame = next(container.decode(stream))
    except (StopIteration, av.FFmpegError):
        return 0
    return _normalise_rotation(frame.rotation)


def _normalise_rotation(degrees: float) -> int:
    """Nearest multiple of 90 in [0, 360); arbitrary angles are not produced by cameras."""
    return round(degrees / 90.0) % 4 * 90


# What `probe` read, by the file's name and identity (device, inode, size, modification time):
# a take probes its video more than once (its chunks, its extraction), and the first frame's
# decode for the rotation made each probe cost as much as 4 detected frames.
_probed: dict[tuple[str, int, int, int, int], VideoInfo] = {}
_PROBED_MAX = 256


def probe(path: PathLike) -> VideoInfo:
    """Read headers (and the first frame, for the rotation) of a video file."""
    name = os.fspath(path)
    try:
        st = os.stat(name)
    except OSError:
        key = None  # open_media says why
    else:
        key = (name, st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)
        if key in _probed:
            return _probed[key]
    info = _probe(name)
    if key is not None:
        if len(_probed) >= _PROBED_MAX:
            _probed.clear()
        _probed[key] = info
    return info


def _probe(name: str) -> VideoInfo:
    with open_media(name) as container:
        stream = _video_stream(container, name)
        audio = container.streams.audio[0] if container.streams.audio else None
        fps = float(stream.average_rate or stream.guessed_rate or 0.0)
        if stream.duration is not None and stream.time_base is not None:
            duration = float(stream.duration * stream.time_base)
        elif container.duration is not None:
            duration = container.duration / av.time_base
        else:
            duration = float("nan")
        w, h = stream.codec_context.width, stream.codec_context.height
        rotation = _rotation(stream, container)
        if rotation in (90, 270):
            w, h = h, w
        if w <= 0 or h <= 0:
            raise InputError(f"{name}: video stream has no frame size")
        return VideoInfo(
            path=name,
            duration_s=duration,
            fps=fps,
            n_frames=int(stream.frames) if stream.frames else None,
            size=(w, h),
            rotation=rotation,
            codec=stream.codec_context.name,
            has_audio=audio is not None,
            audio_codec=None if audio is None else audio.codec_context.name,
        )


def _in_range(t: float, config: VideoConfig) -> bool:
    return t >= config.start_s and (config.end_s is None or t < config.end_s)


# A frame is kept when this share of 1 / max_fps has passed since the last kept one: 60 fps
# footage keeps every second frame at max_fps 30, 30 or 31 fps keeps every frame.
_MIN_STEP = 0.75


class _RateCap:
    """Keeps frames at most `max_fps` times a second, on their own timestamps (VFR-safe)."""

    def __init__(self, max_fps: float | None) -> None:
        self.min_step = _MIN_STEP / max_fps if max_fps else 0.0
        self.last = -np.inf

    def keep(self, t: float) -> bool:
        if t - self.last < self.min_step:
            return False
        self.last = t
        return True


def select_indices(timestamps: np.ndarray, config: VideoConfig) -> np.ndarray:
    """Indices of the frames `iter_frames` keeps: in [start_s, end_s), then every `stride`-th,
    then at most `max_fps` a second.

    timestamps: (T,) seconds of all frames of the video in presentation order.
    """
    ts = np.asarray(timestamps, dtype=np.float64)
    keep = ts >= config.start_s
    if config.end_s is not None:
        keep &= ts < config.end_s
    strided = np.flatnonzero(keep)[:: config.stride]
    cap = _RateCap(config.max_fps)
    return np.array([i for i in strided if cap.keep(float(ts[i]))], dtype=np.int64)


def iter_frames(
    path: PathLike,
    config: VideoConfig | None = None,
    *,
    threads: int | None = None,
    only: Callable[[float], bool] | None = None,
) -> Iterator[tuple[float, np.ndarray]]:
    """Yield `(timestamp_s, frame)` for the frames selected by `config` (time range, stride,
    `max_fps`), one at a time.

    frame: (H, W, 3) uint8 RGB, rotated as the display matrix says. timestamp_s: pts × time_base.
    Frames whose timestamp does not increase (broken muxers) are dropped with a warning, so the
    timestamps are strictly increasing. threads: FFmpeg decoding threads (None = FFmpeg's choice,
    one per core); the frames are the same whatever the count. only: of the selected frames,
    those whose timestamp it accepts (the rest are not converted to RGB; None: all).
    """
    config = config or VideoConfig()
    name = os.fspath(path)
    with open_media(path) as container:
        stream = _video_stream(container, name)
        _set_threads(stream, threads)
        if config.start_s > 0 and stream.time_base is not None:
            # Jump to the keyframe before start_s; frames before start_s are then skipped.
            target = int(config.start_s / stream.time_base) + (stream.start_time or 0)
            try:
                container.seek(target, stream=stream, backward=True)
            except av.FFmpegError:
                container.seek(0)
        last_t = -np.inf
        kept = 0
        cap = _RateCap(config.max_fps)
        damaged = _Damage()
        to_rgb = VideoReformatter()  # one for the stream (_to_rgb)
        try:
            for frame in _decode(container, stream, damaged):
                t = _frame_time(frame, last_t)
                if t is None:
                    continue
                if config.end_s is not None and t >= config.end_s:
                    return
                last_t = t
                if not _in_range(t, config):
                    continue
                kept += 1
                if (kept - 1) % config.stride or not cap.keep(t):
                    continue  # skipped frames are never converted to RGB (the costly part)
                if only is not None and not only(t):
                    continue
                yield t, _to_rgb(frame, to_rgb)
        except av.FFmpegError as exc:
            raise InputError(f"{name}: video is corrupt or truncated ({av_reason(exc)})") from None
        if damaged.packets and not np.isfinite(last_t):
            raise InputError(f"{name}: video is corrupt or truncated ({damaged.reason})")
        if damaged.packets:
            log.warning("%s: %s; the frames that decode are kept", name, damaged.text())
        _check_complete(stream, last_t, name)


def _decode(
    container: av.container.InputContainer,
    stream: av.video.stream.VideoStream,
    damaged: _Damage | None = None,
) -> Iterator[av.VideoFrame]:
    """The stream's frames, decoded packet by packet: a packet that does not decode (a damaged
    stretch of the file) loses its frames, not the rest of the video (noted in `damaged`)."""
    for packet in container.demux(stream):
        try:
            frames = packet.decode()
        except av.FFmpegError as exc:
            if damaged is not None:
                damaged.add(packet, exc)
            continue
        yield from frames


class _Damage:
    """Packets that failed to decode: how many, the time span they cover and the first reason."""

    def __init__(self) -> None:
        self.packets = 0
        self.first, self.last = np.inf, -np.inf
        self.reason = ""

    def add(self, packet: av.Packet, exc: av.FFmpegError) -> None:
        self.packets += 1
        self.reason = self.reason or av_reason(exc)
        if packet.pts is not None and packet.time_base is not None:
            t = float(packet.pts * packet.time_base)
            self.first, self.last = min(self.first, t), max(self.last, t)

    def text(self) -> str:
        where = (
            f" between {self.first:.2f} s and {self.last:.2f} s" if self.first <= self.last else ""
        )
        return f"video damaged: {self.packets} packets do not decode{where} ({self.reason})"


def _set_threads(stream: av.video.stream.VideoStream, threads: int | None) -> None:
    """Frame threads let a lone video's decoding use the spare cores; when every core already
    runs a worker they only add switching, so the builder asks for 1 (build.decode_threads)."""
    stream.codec_context.thread_count = threads or 0  # 0: one per core
    if threads != 1:
        stream.thread_type = "AUTO"  # frame and slice threads


def _check_complete(stream: av.video.stream.VideoStream, last_t: float, name: str) -> None:
    """InputError if decoding stopped well before the end the container declares (a truncated
    file whose index survived: FFmpeg then just stops, without an error)."""
    if stream.duration is None or stream.time_base is None or not np.isfinite(last_t):
        return
    end = float((stream.duration + (stream.start_time or 0)) * stream.time_base)
    step = 1.0 / float(stream.average_rate) if stream.average_rate else 0.1
    if last_t + max(0.5, 3 * step) < end:
        raise InputError(
            f"{name}: video is truncated (frames stop at {last_t:.2f} s of {end:.2f} s)"
        )


def _frame_time(frame: av.VideoFrame, last_t: float) -> float | None:
    if frame.pts is None or frame.time_base is None:
        log.warning("frame without a timestamp dropped (after t=%.3f s)", last_t)
        return None
    t = float(frame.pts * frame.time_base)
    if t <= last_t:
        log.warning("frame at t=%.6f s does not follow t=%.6f s; dropped", t, last_t)
        return None
    return t


def _to_rgb(frame: av.VideoFrame, reformatter: VideoReformatter | None = None) -> np.ndarray:
    """`frame` as (H, W, 3) uint8 RGB, rotated as its display matrix says. `reformatter`: one
    kept for the whole stream. `frame.to_ndarray(format=...)` makes a new one for every frame,
    and with it a new swscale context whose threads (one per core) are started and stopped for
    that one frame: 3.4-4.1 ms of CPU a frame on the demo clips where a kept one takes 0.6-0.75,
    the same pixels (issue 43)."""
    reformatter = reformatter or VideoReformatter()
    rgb = reformatter.reformat(frame, format="rgb24").to_ndarray()
    k = _normalise_rotation(frame.rotation) // 90
    # The display matrix rotates counter-clockwise by `rotation`; np.rot90 turns CCW too.
    return np.ascontiguousarray(np.rot90(rgb, k)) if k else rgb


def frames_at(path: PathLike, times: Sequence[float]) -> list[tuple[float, np.ndarray]]:
    """The frame shown at each of `times` (the last one starting at or before it), as
    (timestamp_s, RGB frame), in the order of `times`.

    Seeks to the keyframe before each time and decodes from there, so a few thumbnails of a
    long video cost a few GOPs of decoding, not the whole file; only the chosen frames are
    converted to RGB.
    """
    name = os.fspath(path)
    found: list[tuple[float, np.ndarray]] = []
    with open_media(path) as container:
        stream = _video_stream(container, name)
        tb = stream.time_base
        if tb is None:
            raise InputError(f"{name}: video stream has no time base")
        try:
            for want in times:
                container.seek(max(0, int(want / tb)) + (stream.start_time or 0), stream=stream)
                best: av.VideoFrame | None = None
                for frame in _decode(container, stream):
                    t = _frame_time(frame, -np.inf)
                    if t is None:
                        continue
                    if t > want + 1e-6 and best is not None:
                        break
                    best = frame
                if best is not None and best.pts is not None and best.time_base is not None:
                    found.append((float(best.pts * best.time_base), _to_rgb(best)))
        except av.FFmpegError as exc:
            raise InputError(f"{name}: video is corrupt or truncated ({av_reason(exc)})") from None
    return found


def frame_timestamps(path: PathLike) -> np.ndarray:
    """(T,) presentation timestamps of every frame, from the packets (no decode; fast).

    Used when only the clock is needed (precomputed keypoints). Packets arrive in decode order,
    so the times are sorted; duplicates are dropped like `iter_frames` does.
    """
    name = os.fspath(path)
    times: list[float] = []
    with open_media(path) as container:
        stream = _video_stream(container, name)
        tb = stream.time_base
        if tb is None:
            raise InputError(f"{name}: video stream has no time base")
        try:
            for packet in container.demux(stream):
                if packet.pts is not None and packet.size > 0:
                    times.append(float(packet.pts * tb))
        except av.FFmpegError as exc:
            raise InputError(f"{name}: video is corrupt or truncated ({av_reason(exc)})") from None
    return np.unique(np.asarray(times, dtype=np.float64))


def first_frame_time(path: PathLike) -> float | None:
    """Timestamp (s) of the first decodable video frame, None if there is none."""
    with open_media(path) as container:
        return _first_video_time(container)


def _first_video_time(container: av.container.InputContainer) -> float | None:
    if not container.streams.video:
        return None
    try:
        for frame in _decode(container, container.streams.video[0]):
            if frame.pts is not None and frame.time_base is not None:
                return float(frame.pts * frame.time_base)
    except av.FFmpegError:
        return None
    return None


def prefetched(
    frames: Iterator[tuple[float, np.ndarray]], size: int = PREFETCH
) -> Iterator[tuple[float, np.ndarray]]:
    """`frames`, decoded by a background thread up to `size` ahead (and PREFETCH_BYTES; PyAV
    releases the GIL while it decodes, the TFLite interpreters while they run). Errors reach
    the consumer."""
    q: queue.Queue[tuple[str, object]] = queue.Queue(maxsize=size)
    stop = threading.Event()

    def produce() -> None:
        try:
            for n, item in enumerate(frames):
                if n == 0:  # the first frame's size bounds how many wait (nothing is queued yet)
                    with q.mutex:
                        q.maxsize = min(size, max(2, PREFETCH_BYTES // max(1, item[1].nbytes)))
                while not stop.is_set():
                    try:
                        q.put(("frame", item), timeout=0.1)
                        break
                    except queue.Full:
                        continue
                if stop.is_set():
                    return
            q.put(("end", None))
        except BaseException as exc:  # handed to the consumer, who re-raises it
            q.put(("error", exc))

    thread = threading.Thread(target=produce, name="decode", daemon=True)
    thread.start()
    try:
        while True:
            kind, item = q.get()
            if kind == "end":
                return
            if kind == "error":
                raise item  # type: ignore[misc]
            yield item  # type: ignore[misc]
    finally:
        stop.set()
        while thread.is_alive():  # unblock a producer waiting on a full queue
            try:
                q.get_nowait()
            except queue.Empty:
                thread.join(timeout=0.05)
