"""2D detectors: the `Detector` contract, the multi-person result type, and the registry.

A detector turns frames into keypoints (DESIGN.md "Contracts"): `detect(frames) -> Pose2D`, one
person. Detectors that can see several people also implement `detect_people(frames) ->
MultiPose2D`; `extract.tracking` then picks the main speaker. Detectors are created by name:

    DETECTORS.create(name, config: DetectorConfig, video=path_or_None) -> Detector

A third-party package adds one through the entry-point group `gesturebank.detectors`, whose
object is such a factory (usually the class). Built-ins are imported only when asked for, so
`import gesturebank` does not import mediapipe.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from gesturebank.errors import InputError
from gesturebank.poses import Pose2D
from gesturebank.registry import Registry
from gesturebank.skeletons import get_skeleton

Frame = tuple[float, np.ndarray]
"""(timestamp_s, (H, W, 3) uint8 RGB image)."""


@runtime_checkable
class Detector(Protocol):
    """Frames in, one person's 2D keypoints out (NaN in frames where nobody is found)."""

    name: str

    def detect(self, frames: Iterable[Frame]) -> Pose2D: ...


@runtime_checkable
class MultiPersonDetector(Detector, Protocol):
    """A detector that reports everybody it sees; tracking chooses whom to keep."""

    def detect_people(self, frames: Iterable[Frame]) -> MultiPose2D: ...


@dataclass(frozen=True, eq=False)
class MultiPose2D:
    """Everybody a detector saw, frame by frame, in unordered slots (no identity yet).

    keypoints:  (T, P, K, 3) float32 x px, y px, confidence; P = most people in one frame; a
                slot nobody fills is all NaN.
    timestamps: (T,) float64 seconds; skeleton, image_size (w, h) as in Pose2D.
    world:      optional (T, P, K, 3) float32 metric landmarks (BlazePose), same slots.
    ids:        optional (T, P) int64 track id of each slot from a detector that tracks people
                itself (-1 = empty slot); None = no identities yet (`extract.tracking` links them).
    """

    keypoints: np.ndarray
    timestamps: np.ndarray
    skeleton: str
    image_size: tuple[int, int]
    world: np.ndarray | None = None
    ids: np.ndarray | None = None

    def __post_init__(self) -> None:
        kp = np.asarray(self.keypoints, dtype=np.float32)
        k = len(get_skeleton(self.skeleton))
        if kp.ndim != 4 or kp.shape[2:] != (k, 3):
            raise InputError(f"MultiPose2D: keypoints must be (T, P, {k}, 3), got {kp.shape}")
        object.__setattr__(self, "keypoints", kp)
        object.__setattr__(self, "timestamps", np.asarray(self.timestamps, dtype=np.float64))
        if self.timestamps.shape != kp.shape[:1]:
            raise InputError("MultiPose2D: timestamps must have one entry per frame")
        if self.world is not None:
            object.__setattr__(self, "world", np.asarray(self.world, dtype=np.float32))
            if self.world.shape != kp.shape:
                raise InputError("MultiPose2D: world must have the shape of keypoints")
        if self.ids is not None:
            object.__setattr__(self, "ids", np.asarray(self.ids, dtype=np.int64))
            if self.ids.shape != kp.shape[:2]:
                raise InputError("MultiPose2D: ids must have shape (T, P)")
        w, h = (int(v) for v in self.image_size)
        object.__setattr__(self, "image_size", (w, h))

    def __len__(self) -> int:
        return len(self.keypoints)

    @property
    def present(self) -> np.ndarray:
        """(T, P) bool: slot holds a person (at least one keypoint with a position)."""
        return np.isfinite(self.keypoints[..., 0]).any(axis=-1)

    @classmethod
    def from_people(
        cls,
        people: list[np.ndarray],
        timestamps: np.ndarray,
        skeleton: str,
        image_size: tuple[int, int],
        world: list[np.ndarray] | None = None,
        ids: list[np.ndarray] | None = None,
    ) -> MultiPose2D:
        """Pack per-frame arrays `(N_t, K, 3)` (N_t may be 0; `ids`: `(N_t,)` track ids) into
        padded slots."""
        k = len(get_skeleton(skeleton))
        p = max((len(x) for x in people), default=0)
        kp = np.full((len(people), max(p, 1), k, 3), np.nan, np.float32)
        wd = None if world is None else np.full_like(kp, np.nan)
        track = None if ids is None else np.full(kp.shape[:2], -1, np.int64)
        for t, x in enumerate(people):
            kp[t, : len(x)] = x
            if wd is not None and world is not None:
                wd[t, : len(world[t])] = world[t]
            if track is not None and ids is not None:
                track[t, : len(ids[t])] = ids[t]
        return cls(kp, timestamps, skeleton, image_size, wd, track)

    @classmethod
    def from_pose2d(cls, pose: Pose2D) -> MultiPose2D:
        """One slot holding a single-person detection."""
        world = None if pose.world is None else pose.world[:, None]
        return cls(pose.keypoints[:, None], pose.timestamps, pose.skeleton, pose.image_size, world)

    def take(self, indices: np.ndarray) -> MultiPose2D:
        """The frames at `indices` (e.g. from `video.select_indices`)."""
        world = None if self.world is None else self.world[indices]
        ids = None if self.ids is None else self.ids[indices]
        return MultiPose2D(
            self.keypoints[indices],
            self.timestamps[indices],
            self.skeleton,
            self.image_size,
            world,
            ids,
        )

    def slot(self, p: int) -> Pose2D:
        """Slot `p` as a Pose2D (only meaningful once slots are identities, see tracking)."""
        world = None if self.world is None else self.world[:, p]
        return Pose2D(self.keypoints[:, p], self.timestamps, self.skeleton, self.image_size, world)

    def to_arrays(self) -> dict[str, np.ndarray]:
        out = {
            "keypoints": self.keypoints,
            "timestamps": self.timestamps,
            "skeleton": np.array(self.skeleton),
            "image_size": np.array(self.image_size, dtype=np.int64),
        }
        if self.world is not None:
            out["world"] = self.world
        if self.ids is not None:
            out["ids"] = self.ids
        return out

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> MultiPose2D:
        size = np.asarray(arrays["image_size"])
        return cls(
            np.asarray(arrays["keypoints"]),
            np.asarray(arrays["timestamps"]),
            str(arrays["skeleton"]),
            (int(size[0]), int(size[1])),
            np.asarray(arrays["world"]) if "world" in arrays else None,
            np.asarray(arrays["ids"]) if "ids" in arrays else None,
        )


DETECTORS: Registry[Detector] = Registry("detector", "gesturebank.detectors")

# Built-ins: name -> "module:attribute", imported on first use.
_BUILTINS = {
    "blazepose": "gesturebank.extract.detectors.blazepose:BlazePoseDetector",
    "mediapipe": "gesturebank.extract.detectors.mediapipe:MediaPipeDetector",
    "openpose-json": "gesturebank.extract.detectors.openpose_json:OpenPoseJsonDetector",
}


for _name, _target in _BUILTINS.items():
    DETECTORS.register_lazy(_name, _target)
