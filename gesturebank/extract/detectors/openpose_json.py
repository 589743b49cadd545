"""Precomputed keypoints: a folder of per-frame OpenPose-format JSON (OpenPose, rtmlib, Pose2Sim).

Each file holds `{"people": [{"pose_keypoints_2d": [x0, y0, c0, x1, ...]}, ...]}` for one frame;
files are ordered by the frame number in their names. The skeleton follows from the keypoint
count (BODY_25, COCO-18, HALPE-26, COCO-17). OpenPose writes (0, 0, 0) for a keypoint it did not
find; that becomes NaN. Frame i's timestamp is the video's i-th frame timestamp when the video is
known, else i / fps.
"""

from __future__ import annotations

import json
import logging
import os
import re
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from gesturebank.config import OpenPoseJsonConfig, TrackingConfig
from gesturebank.errors import ConfigError, InputError
from gesturebank.extract.detectors import Frame
from gesturebank.poses import MultiPose2D, Pose2D
from gesturebank.skeletons import COCO17, HALPE26, OPENPOSE_BODY25, OPENPOSE_COCO18

log = logging.getLogger(__name__)

SKELETON_BY_COUNT = {len(s): s.name for s in (OPENPOSE_BODY25, OPENPOSE_COCO18, HALPE26, COCO17)}


def _natural_key(path: Path) -> tuple[object, ...]:
    """'cam_000010_keypoints.json' sorts after 'cam_000009_keypoints.json' (and 'f2' < 'f10')."""
    parts = re.split(r"(\d+)", path.name)
    return tuple(int(p) if p.isdigit() else p for p in parts)


def json_files(folder: Path) -> list[Path]:
    """The per-frame JSON files of `folder`, in frame order; InputError if there are none."""
    if not folder.is_dir():
        raise InputError(f"{folder}: keypoint folder not found")
    files = sorted(folder.glob("*.json"), key=_natural_key)
    if not files:
        raise InputError(f"{folder}: no OpenPose-format .json files")
    return files


def read_frame(path: Path) -> np.ndarray:
    """(N, K, 3) people of one JSON file (N may be 0); (0,0,0) keypoints become NaN, scores are
    clipped to [0, 1]."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        flat = [p.get("pose_keypoints_2d") or [] for p in data.get("people", [])]
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, AttributeError) as exc:
        raise InputError(f"{path}: not an OpenPose-format JSON file ({exc})") from None
    flat = [f for f in flat if len(f)]
    if not flat:
        return np.zeros((0, 0, 3), np.float32)
    if len({len(f) for f in flat}) != 1 or len(flat[0]) % 3:
        raise InputError(f"{path}: people have keypoint lists of different or odd lengths")
    kp = np.asarray(flat, dtype=np.float32).reshape(len(flat), -1, 3)
    missing = (kp[..., 2] <= 0) | ((kp[..., 0] == 0) & (kp[..., 1] == 0))
    kp[missing] = np.nan
    np.clip(kp[..., 2], 0.0, 1.0, out=kp[..., 2])  # rtmlib's scores can exceed 1
    return kp[~missing.all(axis=1)]


def read_openpose_folder(
    folder: str | os.PathLike[str],
    *,
    timestamps: np.ndarray | None = None,
    fps: float | None = None,
    image_size: tuple[int, int] | None = None,
) -> MultiPose2D:
    """All people of every frame of `folder`: keypoints (T, P, K, 3).

    timestamps: (≥T,) the video's frame times (preferred); else frame i is at i / fps.
    image_size: (w, h); if unknown it is estimated from the keypoints' extent (with a warning).
    """
    root = Path(folder)
    files = json_files(root)
    frames = [read_frame(f) for f in files]
    counts = {x.shape[1] for x in frames if len(x)}
    if len(counts) > 1:
        raise InputError(f"{root}: frames disagree on the keypoint count ({sorted(counts)})")
    k = counts.pop() if counts else len(OPENPOSE_BODY25)
    if k not in SKELETON_BY_COUNT:
        known = ", ".join(f"{n} ({s})" for n, s in SKELETON_BY_COUNT.items())
        raise InputError(f"{root}: {k} keypoints per person is no known skeleton; known: {known}")
    ts = _timestamps(root, len(files), timestamps, fps)
    frames = [x if len(x) else np.zeros((0, k, 3), np.float32) for x in frames]
    size = image_size or _extent(root, frames)
    return MultiPose2D.from_people(frames, ts, SKELETON_BY_COUNT[k], size)


def _timestamps(root: Path, n: int, timestamps: np.ndarray | None, fps: float | None) -> np.ndarray:
    if timestamps is not None:
        ts = np.asarray(timestamps, dtype=np.float64)
        if len(ts) < n:
            raise InputError(f"{root}: {n} keypoint files but the video has only {len(ts)} frames")
        if len(ts) > n:
            log.warning("%s: %d keypoint files for %d video frames", root, n, len(ts))
        return ts[:n]
    if fps is None or fps <= 0:
        raise ConfigError(f"{root}: need the video or a positive fps to time the keypoint files")
    return np.arange(n, dtype=np.float64) / fps


def _extent(root: Path, frames: list[np.ndarray]) -> tuple[int, int]:
    xy = np.concatenate([x[..., :2].reshape(-1, 2) for x in frames])
    if not np.isfinite(xy).any():
        return (1, 1)
    log.warning("%s: image size unknown; estimated from the keypoints' extent", root)
    hi = np.nanmax(xy, axis=0)
    return (max(int(np.ceil(hi[0])), 1), max(int(np.ceil(hi[1])), 1))


class OpenPoseJsonDetector:
    """Reads `<video stem><json_suffix>/` next to the video (or an explicit folder).

    Reading JSON is cheap, so results are not cached (and edits to the JSON are seen at once).
    """

    name = "openpose-json"
    cacheable = False
    needs_pixels = False

    def __init__(
        self,
        config: OpenPoseJsonConfig | None = None,
        *,
        video: str | os.PathLike[str] | None = None,
        folder: str | os.PathLike[str] | None = None,
        fps: float | None = None,
        image_size: tuple[int, int] | None = None,
        tracking: TrackingConfig | None = None,
        threads: int | None = None,  # the constructor convention of every detector; no model
    ) -> None:
        self.config = config or OpenPoseJsonConfig()
        self.video = None if video is None else Path(video)
        if folder is None:
            if self.video is None:
                raise ConfigError("openpose-json: give the video or the keypoint folder")
            folder = self.video.with_name(self.video.stem + self.config.json_suffix)
        self.folder = Path(folder)
        self.fps = fps
        self.image_size = image_size
        self.tracking = tracking or TrackingConfig()

    def detect_people(self, frames: Iterable[Frame] | None = None) -> MultiPose2D:
        """Everybody in the JSON files, timed by `frames` (in order) if given, else the video
        (its packet timestamps; no decode), else fps."""
        timestamps, size = None, self.image_size
        if frames is not None:
            times = []
            for t, image in frames:
                times.append(t)
                size = size or (int(image.shape[1]), int(image.shape[0]))
            timestamps = np.asarray(times, dtype=np.float64)
        elif self.video is not None:
            from gesturebank.extract.video import frame_timestamps, probe

            timestamps = frame_timestamps(self.video)
            size = size or probe(self.video).size
        return read_openpose_folder(
            self.folder, timestamps=timestamps, fps=self.fps, image_size=size
        )

    def detect(self, frames: Iterable[Frame] | None = None) -> Pose2D:
        """The main speaker (see `extract.tracking`) as (T, K, 3)."""
        from gesturebank.extract.tracking import main_speaker

        return main_speaker(self.detect_people(frames), self.tracking, source=str(self.folder)).pose
