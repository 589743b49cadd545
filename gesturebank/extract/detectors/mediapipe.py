"""BlazePose Full through mediapipe's legacy `solutions.pose` (the model mediapipe 0.10.14 bundles).

Video mode with tracking (static_image_mode=False), 33 landmarks in BLAZEPOSE33 order (the same
order mediapipe uses), x/y scaled to pixels, visibility as confidence, world landmarks kept.

The single-person reference for the `blazepose` detector (the same models, several people):
it follows one person and ignores `max_people`.
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

from gesturebank.config import MediaPipeConfig
from gesturebank.errors import ConfigError, DetectionError
from gesturebank.extract.detectors import Frame
from gesturebank.poses import MultiPose2D, Pose2D
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
    """mediapipe BlazePose Full, one person: `detect`, or `detect_people` with one slot."""

    name = "mediapipe"
    skeleton = BLAZEPOSE33.name

    def __init__(
        self,
        config: MediaPipeConfig | None = None,
        *,
        video: object = None,
        threads: int | None = None,  # mediapipe's graph sets its own; accepted for the convention
    ) -> None:
        self.config = config or MediaPipeConfig()
        # Checked before mediapipe is touched: any other complexity makes it download a model.
        if self.config.model_complexity != BUNDLED_COMPLEXITY:
            raise ConfigError(
                f"detector.mediapipe.model_complexity={self.config.model_complexity}: only "
                f"{BUNDLED_COMPLEXITY} (BlazePose Full) is bundled with mediapipe 0.10.14 and "
                "gesturebank never downloads models; set detector.mediapipe.model_complexity = 1 "
                f"(mediapipe install: {INSTALL})"
            )
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
        """(T, 33, 3) keypoints of the one person BlazePose tracks (NaN where none), world
        landmarks (T, 33, 3) metres."""
        return self.detect_people(frames).slot(0)

    def detect_people(self, frames: Iterable[Frame]) -> MultiPose2D:
        """The tracked person in one slot: keypoints (T, 1, 33, 3), world (T, 1, 33, 3)."""
        pose = self._new_pose()
        times: list[float] = []
        people: list[np.ndarray] = []
        worlds: list[np.ndarray] = []
        size: tuple[int, int] | None = None
        empty = np.zeros((0, len(BLAZEPOSE33), 3), np.float32)
        try:
            for t, image in frames:
                h, w = image.shape[:2]
                size = size or (w, h)
                hit = _landmarks(pose.process(image), w, h)
                times.append(t)
                people.append(empty if hit is None else hit[0][None])
                worlds.append(empty if hit is None else hit[1][None])
        finally:
            pose.close()
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
