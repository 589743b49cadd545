"""Rendering Pepper's kinematic model (`pepper.fk`) in 3D (`render3d`) into an MP4 with its audio.

Drawing only: the angles given are drawn as they are, so the caller makes them safe first
(`safety.safe_angles`, or the commands a playback sent). Video through PyAV (H.264, AAC audio).
Video frame k shows the last pose at or before `start + k / fps` on the playback clock (0 = the
audio's first sample); a negative `start` shows the start move before the audio, which is then
delayed to match. Several tracks side by side compare timelines, e.g. prediction vs ground truth,
as in the dissertation's survey videos (§5.2), each with its label; every frame carries the
playback time and, outside the timeline, which safety move is shown.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np

from gesturebank.config import RenderConfig
from gesturebank.errors import InputError
from gesturebank.fileio import atomic_open
from gesturebank.robot.render3d import Camera, Scene

PathLike = str | os.PathLike[str]
AUDIO_RATE = 16000
_TEXT = (20, 20, 20)  # RGB


def poses_at(times: np.ndarray, angles: np.ndarray, *, frame_times: np.ndarray) -> np.ndarray:
    """Zero-order hold: the last pose of `angles (N, 11)` at or before each frame time `(K,)`.

    Frames before the first command show the first pose. Returns `(K, 11)`.
    """
    idx = np.searchsorted(times, frame_times + 1e-9, side="right") - 1
    return angles[np.clip(idx, 0, len(angles) - 1)]


def _audio(path: PathLike | None, duration: float, delay: float) -> np.ndarray | None:
    """The audio, `delay` s of silence first, cut to `duration` s."""
    if path is None:
        return None
    from gesturebank.audio.io import read_audio

    track = read_audio(path, sample_rate=AUDIO_RATE)
    if track is None:
        raise InputError(f"{os.fspath(path)}: no audio track to mux into the video")
    silence = np.zeros(round(max(delay, 0.0) * AUDIO_RATE), np.float32)
    return np.concatenate([silence, track.signal])[: round(duration * AUDIO_RATE)]


def camera(render: RenderConfig) -> Camera:
    """The camera of `render` for one robot's view."""
    return Camera(
        azimuth_deg=render.azimuth_deg,
        elevation_deg=render.elevation_deg,
        distance_m=render.distance_m,
        fov_deg=render.fov_deg,
        width=render.width_px,
        height=render.height_px,
    )


def write_video(
    tracks: Sequence[tuple[str, np.ndarray, np.ndarray]],
    out: PathLike,
    *,
    duration: float,
    audio: PathLike | None = None,
    render: RenderConfig | None = None,
    start: float = 0.0,
    timeline_end: float | None = None,
) -> Path:
    """Render `tracks` = [(label, times (N,), angles (N, 11)), …] side by side for `duration` s
    from playback time `start` (s, ≤ 0 to show a start move; the audio begins at 0).

    `timeline_end` (s): frames from then on are captioned as the return move. The audio (if
    any) is cut to the video. The video is written to a hidden temporary name beside `out` and
    renamed only when complete, so an interrupted render (Ctrl-C) leaves nothing under `out`;
    InputError naming `out` when it cannot be written.
    """
    cfg = render or RenderConfig()
    path = Path(out)
    n_frames = max(1, round(duration * cfg.frame_rate))
    frame_times = start + np.arange(n_frames) / cfg.frame_rate
    poses = [poses_at(times, angles, frame_times=frame_times) for _, times, angles in tracks]
    sound = _audio(audio, n_frames / cfg.frame_rate, -start)
    try:
        with atomic_open(path) as f, av.open(f, mode="w", format="mp4") as container:
            _encode(
                container,
                labels=[label for label, _, _ in tracks],
                poses=poses,
                times=frame_times,
                sound=sound,
                render=cfg,
                timeline_end=timeline_end,
            )
    except (av.FFmpegError, OSError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        folder = getattr(exc, "filename", None)  # e.g. a file where a folder should be
        if folder and Path(folder) in path.parents:
            reason = f"{reason}: {folder}"
        raise InputError(f"{path}: cannot write video ({reason})") from None
    return path


def _caption(t: float, timeline_end: float | None) -> str:
    if t < 0:
        return f"{t:6.2f} s  start move"
    if timeline_end is not None and t >= timeline_end:
        return f"{t:6.2f} s  return to neutral"
    return f"{t:6.2f} s"


def _encode(
    container: av.container.OutputContainer,
    *,
    labels: list[str],
    poses: list[np.ndarray],
    times: np.ndarray,
    sound: np.ndarray | None,
    render: RenderConfig,
    timeline_end: float | None,
) -> None:
    """Render and encode one video frame per `times (K,)` s, then mux `sound` (if any)."""
    scene = Scene(camera(render))
    width, height = render.width_px * len(labels), render.height_px
    vstream = container.add_stream("libx264", rate=render.frame_rate)
    vstream.width, vstream.height, vstream.pix_fmt = width, height, "yuv420p"
    vstream.options = {"crf": "20", "preset": "veryfast"}
    astream = None
    if sound is not None:
        astream = container.add_stream("aac", rate=AUDIO_RATE, layout="mono")
    scale = height / 480
    for k in range(len(times)):
        panels = []
        for label, pose in zip(labels, poses, strict=True):
            img = scene.render(pose[k])
            if label:
                cv2.putText(img, label, (12, round(30 * scale)), cv2.FONT_HERSHEY_SIMPLEX,
                            0.8 * scale, _TEXT, 2, cv2.LINE_AA)  # fmt: skip
            panels.append(img)
        img = np.ascontiguousarray(np.concatenate(panels, axis=1))
        cv2.putText(img, _caption(float(times[k]), timeline_end), (12, height - round(14 * scale)),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.6 * scale, _TEXT, 1, cv2.LINE_AA)  # fmt: skip
        frame = av.VideoFrame.from_ndarray(img, format="rgb24")
        for packet in vstream.encode(frame):
            container.mux(packet)
    container.mux(vstream.encode(None))
    if astream is not None and sound is not None:
        mux_audio(container, astream, x=sound)


def mux_audio(
    container: av.container.OutputContainer, stream: av.AudioStream, *, x: np.ndarray
) -> None:
    """Encode the mono signal `x` (float32 at AUDIO_RATE) into `stream` of `container`."""
    step = 1024  # AAC frame size
    for start in range(0, len(x), step):
        chunk = np.ascontiguousarray(x[start : start + step], dtype=np.float32)[None, :]
        frame = av.AudioFrame.from_ndarray(chunk, format="fltp", layout="mono")
        frame.sample_rate, frame.pts, frame.time_base = AUDIO_RATE, start, Fraction(1, AUDIO_RATE)
        for packet in stream.encode(frame):
            container.mux(packet)
    container.mux(stream.encode(None))
