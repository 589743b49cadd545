"""Drawing Pepper's kinematic model (`pepper.fk`), front and side, into an MP4 with its audio.

Drawing only: the angles given are drawn as they are, so the caller makes them safe first
(`safety.safe_angles`). Video through PyAV (H.264, AAC audio), lines and circles with OpenCV.
Video frame k shows the last pose at or before k / fps. Several tracks side by side compare
timelines, e.g. prediction vs ground truth, as in the dissertation's survey videos (§5.2).

Views (robot frame: x forward, y left, z up): "front" looks at the robot's face, so its left arm
is on the image's right; "side" looks at its right side, forward pointing right.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np

from gesturebank.errors import InputError
from gesturebank.fileio import atomic_open
from gesturebank.robot import pepper

PathLike = str | os.PathLike[str]
AUDIO_RATE = 16000
# Metres shown in a view: wide enough for arms stretched sideways or up.
_HALF_WIDTH_M, _Z_MIN_M, _Z_MAX_M = 0.55, -0.25, 0.75
_BG, _BODY, _LEFT, _RIGHT, _TEXT = (
    (250, 250, 250),
    (90, 90, 90),
    (200, 120, 20),
    (30, 30, 210),
    (0, 0, 0),
)
_BONES = (  # (from, to, colour) — BGR
    ("pelvis", "left_hip", _BODY),
    ("pelvis", "right_hip", _BODY),
    ("left_hip", "left_shoulder", _BODY),
    ("right_hip", "right_shoulder", _BODY),
    ("left_shoulder", "right_shoulder", _BODY),
    ("left_shoulder", "left_elbow", _LEFT),
    ("left_elbow", "left_wrist", _LEFT),
    ("right_shoulder", "right_elbow", _RIGHT),
    ("right_elbow", "right_wrist", _RIGHT),
)


def _project(points: np.ndarray, view: str, size: int) -> np.ndarray:
    """Robot-frame points `(..., 3)` → pixel coordinates `(..., 2)` int in a size × size view."""
    scale = size / max(2 * _HALF_WIDTH_M, _Z_MAX_M - _Z_MIN_M)
    u = points[..., 1] if view == "front" else points[..., 0]
    v = points[..., 2]
    px = size / 2 + u * scale
    py = size - (v - _Z_MIN_M) * scale
    return np.rint(np.stack([px, py], axis=-1)).astype(np.int32)


def draw_view(points: dict[str, np.ndarray], view: str, size: int, label: str = "") -> np.ndarray:
    """One view `(size, size, 3)` uint8 BGR of one pose given as fk points (each `(3,)`)."""
    img = np.full((size, size, 3), _BG, np.uint8)
    px = {k: tuple(int(c) for c in _project(p, view, size)) for k, p in points.items()}
    # Ground line and the torso as a filled outline first, so the arms draw over them.
    cv2.line(img, (0, size - 4), (size, size - 4), (200, 200, 200), 2)
    for a, b, colour in _BONES:
        cv2.line(img, px[a], px[b], colour, max(2, size // 90), cv2.LINE_AA)
    for joint in ("left_elbow", "right_elbow", "left_shoulder", "right_shoulder"):
        cv2.circle(img, px[joint], max(3, size // 80), _BODY, -1, cv2.LINE_AA)
    for joint, colour in (("left_wrist", _LEFT), ("right_wrist", _RIGHT)):
        cv2.circle(img, px[joint], max(4, size // 60), colour, -1, cv2.LINE_AA)
    head_r = max(6, int(0.09 * size / max(2 * _HALF_WIDTH_M, _Z_MAX_M - _Z_MIN_M)))
    neck = tuple((np.array(px["left_shoulder"]) + np.array(px["right_shoulder"])) // 2)
    cv2.line(img, neck, px["head"], _BODY, max(2, size // 90), cv2.LINE_AA)
    face = (np.array(px["left_eye"]) + np.array(px["right_eye"])) // 2
    cv2.circle(img, tuple(int(c) for c in face), head_r, _BODY, 2, cv2.LINE_AA)
    cv2.circle(img, px["nose"], max(2, size // 120), (0, 160, 0), -1, cv2.LINE_AA)
    text = f"{label} {view}".strip()
    cv2.putText(img, text, (8, 22), cv2.FONT_HERSHEY_SIMPLEX, size / 700, _TEXT, 1, cv2.LINE_AA)
    return img


def poses_at(times: np.ndarray, angles: np.ndarray, frame_times: np.ndarray) -> np.ndarray:
    """Zero-order hold: the last pose of `angles (N, 11)` at or before each frame time `(K,)`.

    Frames before the first command show the first pose. Returns `(K, 11)`.
    """
    idx = np.searchsorted(times, frame_times + 1e-9, side="right") - 1
    return angles[np.clip(idx, 0, len(angles) - 1)]


def _audio(path: PathLike | None, duration: float) -> np.ndarray | None:
    if path is None:
        return None
    from gesturebank.extract.audio_io import read_audio

    track = read_audio(path, sample_rate=AUDIO_RATE)
    if track is None:
        raise InputError(f"{os.fspath(path)}: no audio track to mux into the video")
    return track.signal[: round(duration * AUDIO_RATE)]


def write_video(
    tracks: Sequence[tuple[str, np.ndarray, np.ndarray]],
    out: PathLike,
    *,
    duration: float,
    audio: PathLike | None = None,
    fps: int = 25,
    view_px: int = 360,
) -> Path:
    """Render `tracks` = [(label, times (N,), angles (N, 11)), …] side by side for `duration` s.

    Each track gets a front and a side view. The audio (if any) is cut to `duration`.
    The video is written to a hidden temporary name beside `out` and renamed only when complete,
    so an interrupted render (Ctrl-C) leaves nothing under `out`; InputError naming `out` when
    it cannot be written.
    """
    path = Path(out)
    n_frames = max(1, round(duration * fps))
    frame_times = np.arange(n_frames) / fps
    points = [pepper.fk(poses_at(times, angles, frame_times)) for _, times, angles in tracks]
    sound = _audio(audio, n_frames / fps)
    try:
        with atomic_open(path) as f, av.open(f, mode="w", format="mp4") as container:
            _encode(
                container,
                tracks=tracks,
                points=points,
                times=frame_times,
                sound=sound,
                view_px=view_px,
                fps=fps,
            )
    except (av.FFmpegError, OSError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        folder = getattr(exc, "filename", None)  # e.g. a file where a folder should be
        if folder and Path(folder) in path.parents:
            reason = f"{reason}: {folder}"
        raise InputError(f"{path}: cannot write video ({reason})") from None
    return path


def _encode(
    container: av.container.OutputContainer,
    *,
    tracks: Sequence[tuple[str, np.ndarray, np.ndarray]],
    points: list[dict[str, np.ndarray]],
    times: np.ndarray,
    sound: np.ndarray | None,
    view_px: int,
    fps: int,
) -> None:
    """Draw and encode one video frame per `times (K,)` s, then mux `sound` (if any)."""
    width = 2 * view_px * len(tracks)
    vstream = container.add_stream("libx264", rate=fps)
    vstream.width, vstream.height, vstream.pix_fmt = width, view_px, "yuv420p"
    vstream.options = {"crf": "20", "preset": "veryfast"}
    astream = None
    if sound is not None:
        astream = container.add_stream("aac", rate=AUDIO_RATE, layout="mono")
    for k in range(len(times)):
        panels = []
        for (label, _, _), pts in zip(tracks, points, strict=True):
            pose = {name: p[k] for name, p in pts.items()}
            panels += [draw_view(pose, v, view_px, label) for v in ("front", "side")]
        img = np.concatenate(panels, axis=1)
        cv2.putText(img, f"{times[k]:6.2f} s", (width - 110, view_px - 12),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.5, _TEXT, 1, cv2.LINE_AA)  # fmt: skip
        frame = av.VideoFrame.from_ndarray(img, format="bgr24")
        for packet in vstream.encode(frame):
            container.mux(packet)
    container.mux(vstream.encode(None))
    if astream is not None and sound is not None:
        _mux_audio(container, astream, sound)


def _mux_audio(
    container: av.container.OutputContainer, stream: av.AudioStream, x: np.ndarray
) -> None:
    step = 1024  # AAC frame size
    for start in range(0, len(x), step):
        chunk = np.ascontiguousarray(x[start : start + step], dtype=np.float32)[None, :]
        frame = av.AudioFrame.from_ndarray(chunk, format="fltp", layout="mono")
        frame.sample_rate, frame.pts, frame.time_base = AUDIO_RATE, start, Fraction(1, AUDIO_RATE)
        for packet in stream.encode(frame):
            container.mux(packet)
    container.mux(stream.encode(None))
