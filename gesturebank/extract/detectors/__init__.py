"""2D detectors: the `Detector` contracts and the registry.

A detector turns frames into keypoints (docs/architecture.md "Contracts"):
`detect(frames) -> Pose2D`, one
person. Detectors that can see several people also implement `detect_people(frames) ->
MultiPose2D` (both types in `gesturebank.poses`); `extract.tracking` then picks the main speaker.
Detectors are created by name:

    DETECTORS.create(name, settings, video=path_or_None) -> Detector

where `settings` is the detector's own `[detector.NAME]` section (`DetectorConfig.settings()`:
`BlazePoseConfig` …; None for a plug-in that declares no `section_model`). A third-party package
adds one through the entry-point group `gesturebank.detectors`, whose object is such a factory
(usually the class; its `section_model`, a pydantic model, validates its section). Built-ins
are imported only when asked for, so `import gesturebank` does not import mediapipe.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Protocol, runtime_checkable

import numpy as np

from gesturebank.poses import MultiPose2D, Pose2D
from gesturebank.registry import Registry

Frame = tuple[float, np.ndarray]
"""(timestamp_s, (H, W, 3) uint8 RGB image)."""
# A detector's optional per-frame report: (frame index, t, RGB image, keypoints (P, K, 3),
# track ids (P,)), called as each frame's people are found (`extract.face_pass`).
PeopleHook = Callable[[int, float, np.ndarray, np.ndarray, np.ndarray], None]


@runtime_checkable
class Detector(Protocol):
    """Frames in, one person's 2D keypoints out (NaN in frames where nobody is found).

    Optional attributes: `version` (int, default 0), part of the detection cache's key — bump
    it when the same video gives other output; `cacheable = False` keeps it out of the cache.
    """

    name: str

    def detect(self, frames: Iterable[Frame]) -> Pose2D: ...


@runtime_checkable
class MultiPersonDetector(Detector, Protocol):
    """A detector that reports everybody it sees; tracking chooses whom to keep."""

    def detect_people(self, frames: Iterable[Frame]) -> MultiPose2D: ...


DETECTORS: Registry[Detector] = Registry("detector", "gesturebank.detectors")

# Built-ins: name -> "module:attribute", imported on first use.
_BUILTINS = {
    "blazepose": "gesturebank.extract.detectors.blazepose:BlazePoseDetector",
    "mediapipe": "gesturebank.extract.detectors.mediapipe:MediaPipeDetector",
    "openpose-json": "gesturebank.extract.detectors.openpose_json:OpenPoseJsonDetector",
}


for _name, _target in _BUILTINS.items():
    DETECTORS.register_lazy(_name, _target)
