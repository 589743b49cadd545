"""Audio decoding with PyAV: the first audio track of a video or of a .wav file, as mono float32.

The track is placed on the video's clock (`Audio.start_s`, `Audio.start_offset_s`), so speech and
poses line up whatever frames were selected. Every failure to read a file is an `InputError`
whose one-line message names the file. Audio features are `audio_features`.
"""

from __future__ import annotations

import logging
import os
from typing import NamedTuple

import av
import numpy as np

from gesturebank.errors import InputError
from gesturebank.extract.video import PathLike, av_reason, first_frame_time, open_media

log = logging.getLogger(__name__)


class Audio(NamedTuple):
    """A decoded audio track.

    signal:         (N,) float32 mono in [-1, 1].
    sample_rate:    Hz.
    start_offset_s: time of sample 0 minus the time of the first video frame of the file,
                    seconds (0 when the file has no video).
    start_s:        time of sample 0 on the clock of the video's timestamps (Pose2D.timestamps),
                    so sample n plays at start_s + n / sample_rate whatever frames were selected.
    """

    signal: np.ndarray
    sample_rate: int
    start_offset_s: float
    start_s: float = 0.0


def read_audio(path: PathLike, *, sample_rate: int) -> Audio | None:
    """The first audio track as mono float32 at `sample_rate`, or None if the file has none.

    Channels are averaged; the rate is converted by FFmpeg's swresample (windowed-sinc filter,
    i.e. band-limited with anti-aliasing). The whole track is returned (audio is small: 1 h at
    16 kHz is 230 MB).
    """
    name = os.fspath(path)
    with open_media(path) as container:
        if not container.streams.audio:
            return None
        stream = container.streams.audio[0]
        resampler = av.AudioResampler(format="fltp", rate=sample_rate)
        chunks: list[np.ndarray] = []
        audio_t0: float | None = None
        samples, damaged, reason = 0, 0, ""
        try:
            for packet in container.demux(stream):
                try:  # packet by packet: a damaged stretch becomes silence, in its place
                    frames = packet.decode()
                except av.FFmpegError as exc:
                    damaged, reason = damaged + 1, reason or av_reason(exc)
                    continue
                for frame in frames:
                    t = _time(frame)
                    if audio_t0 is None:
                        audio_t0 = t
                    elif damaged and t is not None:
                        gap = round((t - audio_t0) * sample_rate) - samples
                        if gap > sample_rate // 50:  # the samples of the packets lost
                            chunks.append(np.zeros(gap, np.float32))
                            samples += gap
                    for out in resampler.resample(frame):
                        chunks.append(_mono(out))
                        samples += len(chunks[-1])
            chunks.extend(_mono(out) for out in resampler.resample(None))
        except av.FFmpegError as exc:
            raise InputError(f"{name}: audio is corrupt or truncated ({av_reason(exc)})") from None
        if damaged and not chunks:
            raise InputError(f"{name}: audio is corrupt or truncated ({reason})")
        if damaged:
            log.warning("%s: audio damaged: %d packets do not decode, silent there", name, damaged)
    video_t0 = first_frame_time(path)
    signal = np.concatenate(chunks) if chunks else np.zeros(0, np.float32)
    start = audio_t0 or 0.0
    offset = start - (video_t0 if video_t0 is not None else 0.0)
    return Audio(signal.astype(np.float32, copy=False), sample_rate, offset, start)


def _time(frame: av.AudioFrame) -> float | None:
    if frame.pts is None or frame.time_base is None:
        return None
    return float(frame.pts * frame.time_base)


def _mono(frame: av.AudioFrame) -> np.ndarray:
    """(n,) mean of the channels of a planar float frame."""
    return frame.to_ndarray().mean(axis=0, dtype=np.float32)
