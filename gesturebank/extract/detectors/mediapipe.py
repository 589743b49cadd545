"""BlazePose Full through mediapipe's legacy `solutions.pose` (the model mediapipe 0.10.14 bundles).

Video mode with tracking (static_image_mode=False), 33 landmarks in BLAZEPOSE33 order (the same
order mediapipe uses), x/y scaled to pixels, visibility as confidence, world landmarks kept.

BlazePose is single-person. With `max_people > 1` this detector finds more people by masking
each one it found and running another (independently tracking) BlazePose on the masked frame;
the slots carry no identity, `extract.tracking` links them.
"""

from __future__ import annotations

import importlib.util
import logging
import os
import sys
import warnings
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from gesturebank.config import DetectorConfig
from gesturebank.errors import ConfigError, DetectionError
from gesturebank.extract.detectors import Frame, MultiPose2D
from gesturebank.poses import Pose2D
from gesturebank.skeletons import BLAZEPOSE33

log = logging.getLogger(__name__)

INSTALL = (
    'pip install absl-py attrs flatbuffers matplotlib "protobuf>=4.25.3,<5" '
    "&& pip install --no-deps mediapipe==0.10.14"
)
BUNDLED_COMPLEXITY = 1  # only pose_landmark_full.tflite ships in the wheel
_MODEL = Path("modules") / "pose_landmark" / "pose_landmark_full.tflite"


def _check_install() -> None:
    """DetectionError with the install command unless mediapipe and its bundled model exist."""
    spec = importlib.util.find_spec("mediapipe")
    if spec is None or not spec.submodule_search_locations:
        raise DetectionError(f"detector 'mediapipe' needs the mediapipe package: {INSTALL}")
    root = Path(next(iter(spec.submodule_search_locations)))
    if not (root / _MODEL).is_file() or not (root / "python" / "solutions" / "pose.py").is_file():
        raise DetectionError(
            f"the installed mediapipe ({root}) has no bundled BlazePose model "
            f"(releases after 0.10.21 dropped it): {INSTALL}"
        )


# mediapipe 0.10.14 calls a deprecated protobuf API on every frame; the warning is not ours to fix.
warnings.filterwarnings("ignore", message=r".*SymbolDatabase\.GetPrototype", category=UserWarning)


@contextmanager
def _quiet_startup() -> Iterator[None]:
    """Silence what mediapipe's C++ core and protobuf print while the graph starts.

    TFLite and glog write straight to file descriptor 2 (no Python logging or env switch stops
    them), so fd 2 points at /dev/null for the duration; exceptions still propagate.
    """
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


class MediaPipeDetector:
    """mediapipe BlazePose Full; `detect` for one person, `detect_people` for up to max_people."""

    name = "mediapipe"
    skeleton = BLAZEPOSE33.name

    def __init__(
        self, config: DetectorConfig | None = None, *, video: object = None, max_people: int = 1
    ) -> None:
        self.config = config or DetectorConfig()
        # Checked before mediapipe is touched: any other complexity makes it download a model.
        if self.config.model_complexity != BUNDLED_COMPLEXITY:
            raise ConfigError(
                f"detector.model_complexity={self.config.model_complexity}: only "
                f"{BUNDLED_COMPLEXITY} (BlazePose Full) is bundled with mediapipe 0.10.14 and "
                "gesturebank never downloads models; set detector.model_complexity = 1 "
                f"(mediapipe install: {INSTALL})"
            )
        if max_people < 1:
            raise ConfigError(f"max_people must be at least 1, got {max_people}")
        self.max_people = max_people
        _check_install()

    def _new_pose(self) -> Any:
        with _quiet_startup():
            from mediapipe.python.solutions import pose as mp_pose  # heavy, only when used

            pose = mp_pose.Pose(
                static_image_mode=False,
                model_complexity=BUNDLED_COMPLEXITY,
                smooth_landmarks=True,
                enable_segmentation=False,
                min_detection_confidence=self.config.min_detection_confidence,
                min_tracking_confidence=self.config.min_tracking_confidence,
            )
            # the graph starts (and logs) on the first frame: do it now, quietly
            pose.process(np.zeros((64, 64, 3), np.uint8))
        return pose

    def detect(self, frames: Iterable[Frame]) -> Pose2D:
        """(T, 33, 3) keypoints of the one person BlazePose tracks (NaN where none)."""
        if self.max_people == 1:
            return self.detect_people(frames).slot(0)
        from gesturebank.extract.tracking import main_speaker

        return main_speaker(self.detect_people(frames)).pose

    def detect_people(self, frames: Iterable[Frame]) -> MultiPose2D:
        """Up to `max_people` people per frame: keypoints (T, P, 33, 3), world (T, P, 33, 3)."""
        poses = [self._new_pose() for _ in range(self.max_people)]
        times: list[float] = []
        people: list[np.ndarray] = []
        worlds: list[np.ndarray] = []
        size: tuple[int, int] | None = None
        try:
            for t, image in frames:
                h, w = image.shape[:2]
                size = size or (w, h)
                kp, wd = _detect_frame(poses, image)
                times.append(t)
                people.append(kp)
                worlds.append(wd)
        finally:
            for p in poses:
                p.close()
        if size is None:
            raise DetectionError("mediapipe: no frames to detect on")
        return MultiPose2D.from_people(people, np.asarray(times), self.skeleton, size, worlds)


def _landmarks(result: Any, w: int, h: int) -> tuple[np.ndarray, np.ndarray] | None:
    """((33, 3) x px, y px, visibility; (33, 3) world metres) of one result, or None."""
    if result.pose_landmarks is None:
        return None
    lm = result.pose_landmarks.landmark
    kp = np.array([(p.x * w, p.y * h, p.visibility) for p in lm], dtype=np.float32)
    np.clip(kp[:, 2], 0.0, 1.0, out=kp[:, 2])
    if result.pose_world_landmarks is not None:
        wl = result.pose_world_landmarks.landmark
        world = np.array([(p.x, p.y, p.z) for p in wl], dtype=np.float32)
    else:
        world = np.full((len(lm), 3), np.nan, np.float32)
    return kp, world


def _detect_frame(poses: list[Any], image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Run each BlazePose in turn, masking everyone already found. Returns (N, 33, 3) twice."""
    h, w = image.shape[:2]
    found: list[tuple[np.ndarray, np.ndarray]] = []
    current = image
    for i, pose in enumerate(poses):
        hit = _landmarks(pose.process(current), w, h)
        if hit is not None and not any(_same_person(hit[0], f[0]) for f in found):
            found.append(hit)
        if i + 1 < len(poses) and hit is not None:
            current = _mask(current if current is not image else image.copy(), hit[0])
    if not found:
        empty = np.zeros((0, len(BLAZEPOSE33), 3), np.float32)
        return empty, empty
    return np.stack([f[0] for f in found]), np.stack([f[1] for f in found])


def _bbox(kp: np.ndarray, pad: float = 0.1) -> tuple[float, float, float, float]:
    x0, y0 = np.nanmin(kp[:, :2], axis=0)
    x1, y1 = np.nanmax(kp[:, :2], axis=0)
    px, py = pad * (x1 - x0), pad * (y1 - y0)
    return x0 - px, y0 - py, x1 + px, y1 + py


def _mask(image: np.ndarray, kp: np.ndarray) -> np.ndarray:
    """Blank the padded bounding box of `kp` in place (so the next BlazePose looks elsewhere)."""
    h, w = image.shape[:2]
    x0, y0, x1, y1 = _bbox(kp)
    c0, r0 = max(int(x0), 0), max(int(y0), 0)
    c1, r1 = min(int(np.ceil(x1)), w), min(int(np.ceil(y1)), h)
    if c1 > c0 and r1 > r0:
        image[r0:r1, c0:c1] = 0
    return image


def _same_person(a: np.ndarray, b: np.ndarray) -> bool:
    """Two detections of one person: mean keypoint distance under 10 % of the body's size."""
    x0, y0, x1, y1 = _bbox(b, pad=0.0)
    scale = max(x1 - x0, y1 - y0, 1.0)
    return float(np.nanmean(np.linalg.norm(a[:, :2] - b[:, :2], axis=-1))) < 0.1 * scale
