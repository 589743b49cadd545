"""Shot boundaries (scene cuts) found in the frames the pose detector already sees.

The detector is PySceneDetect's `ContentDetector`, fed one frame at a time (the video is decoded
once, for the pose detector and for this). As PySceneDetect's own `SceneManager` does, frames are
shrunk so that their longer side is about 256 px before the HSV comparison, which keeps the cost
per frame small and the threshold meaning what it means on PySceneDetect's command line.

Time is the frames' real timestamps: `min_shot_s` is compared in seconds, so variable frame rate
footage and a frame subset (`video.max_fps`) need no frame-count conversion.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from fractions import Fraction
from itertools import pairwise
from typing import Any

import numpy as np

from gesturebank.config import ShotsConfig
from gesturebank.errors import DetectionError

INSTALL = "pip install --no-deps scenedetect==0.7.2 && pip install click platformdirs tqdm"

# PySceneDetect's SceneManager shrinks frames until the longer side is this many pixels.
ANALYSIS_SIDE = 256

# Timestamps go to PySceneDetect as integer nanoseconds after the first frame.
_TIME_BASE = Fraction(1, 1_000_000_000)


@dataclass(frozen=True)
class Shots:
    """Where a take changes shot.

    timestamps: (T,) float64 seconds of the analysed frames, strictly increasing.
    cuts:       (S,) float64 timestamp of the first frame of each new shot, sorted; each is one of
                `timestamps` after the first (a take with no cut: empty).
    change:     (T,) float32 content change of each frame against the previous analysed one
                (ContentDetector's `content_val`, 0–255: what `threshold` is compared with);
                NaN for the first frame.
    """

    timestamps: np.ndarray
    cuts: np.ndarray
    change: np.ndarray

    def __post_init__(self) -> None:
        ts = np.asarray(self.timestamps, dtype=np.float64)
        cuts = np.asarray(self.cuts, dtype=np.float64)
        change = np.asarray(self.change, dtype=np.float32)
        if ts.ndim != 1 or cuts.ndim != 1 or change.shape != ts.shape:
            raise ValueError(
                f"Shots: timestamps (T,), cuts (S,), change (T,) expected, got "
                f"{ts.shape}, {cuts.shape}, {change.shape}"
            )
        if np.any(np.diff(ts) <= 0):
            raise ValueError("Shots: timestamps must be strictly increasing")
        if np.any(np.diff(cuts) <= 0) or not np.isin(cuts, ts[1:]).all():
            raise ValueError("Shots: cuts must be sorted timestamps of frames after the first")
        object.__setattr__(self, "timestamps", ts)
        object.__setattr__(self, "cuts", cuts)
        object.__setattr__(self, "change", change)

    def spans(self) -> list[tuple[int, int]]:
        """[start, stop) frame indices of each shot, in order; together they cover every frame
        exactly once (no frames: no spans)."""
        n = len(self.timestamps)
        if n == 0:
            return []
        bounds = [0, *np.searchsorted(self.timestamps, self.cuts).tolist(), n]
        return list(pairwise(bounds))

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Plain arrays for the detection cache (npz, no pickle)."""
        return {"timestamps": self.timestamps, "cuts": self.cuts, "change": self.change}

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> Shots:
        return cls(arrays["timestamps"], arrays["cuts"], arrays["change"])


def _scenedetect() -> Any:
    """PySceneDetect's modules, imported on first use (it imports OpenCV: 0.5 s)."""
    try:
        import scenedetect.common
        import scenedetect.detector
        import scenedetect.detectors
    except ImportError as exc:
        raise DetectionError(
            f"shots: PySceneDetect is not importable ({exc}); install it with: {INSTALL}"
        ) from None
    return scenedetect


def analysis_size(width: int, height: int) -> tuple[int, int]:
    """(width, height) a frame is shrunk to: the longer side ≈ ANALYSIS_SIDE, as PySceneDetect's
    SceneManager does (smaller frames are used as they are)."""
    factor = max(width, height) / ANALYSIS_SIDE
    if factor <= 1:
        return width, height
    return max(1, round(width / factor)), max(1, round(height / factor))


class ShotDetector:
    """Streaming shot detector: `push` every analysed frame in order, then `result()`.

    detector "content": ContentDetector cuts (threshold, min_shot_s from `config`).
    detector "none":    the take is one shot (no cuts), but `change` is still measured, so the
                        still-picture check and the dashboard work on footage known to be uncut.
    Both need PySceneDetect; without it the constructor raises DetectionError.
    """

    def __init__(self, config: ShotsConfig) -> None:
        self._config = config
        sd = _scenedetect()
        self._frame_timecode, self._timecode = sd.common.FrameTimecode, sd.common.Timecode
        self._detector = sd.detectors.ContentDetector(
            threshold=config.threshold,
            # A float is seconds: the flash filter compares the frames' own times.
            min_scene_len=float(config.min_shot_s),
            # SUPPRESS: a cut closer than min_shot_s to the last reported one is dropped.
            # PySceneDetect's default, MERGE, after two close cuts also drops every later cut
            # until one comes min_shot_s after the burst (found here: a 1 s shot after a
            # 0.2 s and a 0.4 s one was lost), and holds cuts back, losing them at the end.
            filter_mode=sd.detector.FlashFilter.Mode.SUPPRESS,
        )
        if not hasattr(self._detector, "_frame_score"):
            raise DetectionError(
                f"shots: this PySceneDetect is not 0.7.2; install it with: {INSTALL}"
            )
        self._times: list[float] = []
        self._change: list[float] = []
        self._pts: list[int] = []
        self._cut_pts: list[int] = []
        self._size: tuple[int, int] | None = None

    def push(self, timestamp_s: float, frame: np.ndarray) -> None:
        """Add the next frame. frame: (H, W, 3) uint8 RGB; timestamp_s: seconds, increasing."""
        if frame.ndim != 3 or frame.shape[2] != 3 or frame.dtype != np.uint8:
            raise ValueError(
                f"shots: frame must be (H, W, 3) uint8, got {frame.shape} {frame.dtype}"
            )
        t = float(timestamp_s)
        if self._times and t <= self._times[-1]:
            raise ValueError(f"shots: frame at {t:.6f} s does not follow {self._times[-1]:.6f} s")
        if self._size is None:
            self._size = analysis_size(frame.shape[1], frame.shape[0])
        pts = round((t - (self._times[0] if self._times else t)) / _TIME_BASE)
        # Frame rate = 1 / time base, so PySceneDetect's frame numbers are the pts themselves.
        timecode = self._frame_timecode(
            self._timecode(pts=pts, time_base=_TIME_BASE), fps=1 / _TIME_BASE
        )
        cuts = self._detector.process_frame(timecode, _bgr_small(frame, self._size))
        # The score ContentDetector just compared with the threshold (0 on its first frame, where
        # there is nothing to compare). The public route, a stats manager, would make it compute
        # Canny edge maps as well: 1.5 instead of 0.4 ms a frame, for a metric we do not use.
        self._change.append(self._detector._frame_score if self._times else np.nan)
        self._times.append(t)
        self._pts.append(pts)
        self._cut_pts.extend(int(c.pts) for c in cuts)

    def result(self) -> Shots:
        """The shots of the frames pushed so far (the flash filter holds no cut back)."""
        times = np.asarray(self._times, dtype=np.float64)
        if self._config.detector == "none" or not self._cut_pts:
            cuts = np.zeros(0, np.float64)
        else:
            index = np.searchsorted(np.asarray(self._pts), sorted(set(self._cut_pts)))
            cuts = times[index]
        return Shots(times, cuts, np.asarray(self._change, dtype=np.float32))


def _bgr_small(frame: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(h, w, 3) uint8 BGR at the analysis size (ContentDetector expects OpenCV's BGR order;
    a frame of another size than the first is brought to the same size)."""
    import cv2

    if (frame.shape[1], frame.shape[0]) != size:
        frame = cv2.resize(frame, size, interpolation=cv2.INTER_LINEAR)
    return cv2.cvtColor(frame, cv2.COLOR_RGB2BGR)


def detect_shots(frames: Iterable[tuple[float, np.ndarray]], config: ShotsConfig) -> Shots:
    """Shots of a stream of `(timestamp_s, RGB (H, W, 3) uint8)` frames (e.g. `iter_frames`)."""
    detector = ShotDetector(config)
    for t, frame in frames:
        detector.push(t, frame)
    return detector.result()
