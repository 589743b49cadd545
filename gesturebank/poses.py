"""Pose2D / MultiPose2D / Pose3D: the arrays that travel between stages
(docs/architecture.md "Contracts").

Pose2D is one person's 2D keypoints, MultiPose2D everybody a detector saw (unordered slots, the
input of tracking), Pose3D one person's 3D joints. They validate shapes and dtypes on
construction, keep missing values as NaN (never 0), carry their own timestamps (variable frame
rate is real), and round-trip through `.npz` without pickle.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from gesturebank.errors import InputError
from gesturebank.geometry import CameraGroup
from gesturebank.skeletons import COCO17, get_skeleton

Units = Literal["m", "relative"]


def _timestamps(ts: np.ndarray, n: int, what: str) -> np.ndarray:
    ts = np.asarray(ts, dtype=np.float64)
    if ts.shape != (n,):
        raise InputError(f"{what}: timestamps must have shape ({n},), got {ts.shape}")
    if not np.all(np.isfinite(ts)):
        raise InputError(f"{what}: timestamps must be finite")
    if n > 1 and not np.all(np.diff(ts) > 0):
        raise InputError(f"{what}: timestamps must be strictly increasing")
    return ts


def _confidence(c: np.ndarray, what: str) -> None:
    finite = c[np.isfinite(c)]
    if finite.size and (finite.min() < 0 or finite.max() > 1):
        raise InputError(f"{what}: confidence must lie in [0, 1]")


@dataclass(frozen=True, eq=False)
class Pose2D:
    """2D keypoints of one person over a take.

    keypoints:  (T, K, 3) float32 — x px, y px, confidence in [0, 1]; NaN = missing.
    timestamps: (T,) float64 seconds in the video's own time base.
    skeleton:   name of the keypoint set (see `gesturebank.skeletons`).
    image_size: (width, height) in pixels.
    world:      optional (T, K, 3) float32 metric 3D landmarks the detector predicts with its 2D
                output (BlazePose world landmarks, metres, origin between the hips), for the
                learned lifter.
    """

    keypoints: np.ndarray
    timestamps: np.ndarray
    skeleton: str
    image_size: tuple[int, int]
    world: np.ndarray | None = None

    def __post_init__(self) -> None:
        kp = np.asarray(self.keypoints, dtype=np.float32)
        skel = get_skeleton(self.skeleton)
        if kp.ndim != 3 or kp.shape[1:] != (len(skel), 3):
            raise InputError(
                f"Pose2D: keypoints must have shape (T, {len(skel)}, 3) for skeleton "
                f"{skel.name!r}, got {kp.shape}"
            )
        if np.any(np.isnan(kp[..., 0]) != np.isnan(kp[..., 1])):
            raise InputError("Pose2D: a keypoint has x or y missing but not both")
        _confidence(kp[..., 2], "Pose2D")
        object.__setattr__(self, "keypoints", kp)
        object.__setattr__(self, "timestamps", _timestamps(self.timestamps, len(kp), "Pose2D"))
        w, h = (int(v) for v in self.image_size)
        if w <= 0 or h <= 0:
            raise InputError(f"Pose2D: image_size must be positive, got {self.image_size}")
        object.__setattr__(self, "image_size", (w, h))
        if self.world is not None:
            world = np.asarray(self.world, dtype=np.float32)
            if world.shape != kp.shape:
                raise InputError(f"Pose2D: world must have shape {kp.shape}, got {world.shape}")
            object.__setattr__(self, "world", world)

    def __len__(self) -> int:
        return len(self.keypoints)

    @property
    def xy(self) -> np.ndarray:
        """(T, K, 2) pixel coordinates."""
        return self.keypoints[..., :2]

    @property
    def confidence(self) -> np.ndarray:
        """(T, K) confidence."""
        return self.keypoints[..., 2]

    def frames(self, start: int, stop: int, *, origin_s: float = 0.0) -> Pose2D:
        """Frames [start, stop), on a clock whose 0 is `origin_s` of this one."""
        world = None if self.world is None else self.world[start:stop]
        return replace(
            self,
            keypoints=self.keypoints[start:stop],
            timestamps=self.timestamps[start:stop] - origin_s,
            world=world,
        )

    def to_coco17(self) -> Pose2D:
        """The same pose in COCO-17 order (joints the skeleton lacks become NaN)."""
        src = get_skeleton(self.skeleton)
        world = None if self.world is None else src.convert(self.world, COCO17)
        return Pose2D(
            src.convert(self.keypoints, COCO17),
            self.timestamps,
            COCO17.name,
            self.image_size,
            world,
        )

    def to_arrays(self, prefix: str = "") -> dict[str, np.ndarray]:
        return _keypoint_arrays(self, prefix)

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray], prefix: str = "") -> Pose2D:
        return cls(**_keypoint_fields(arrays, prefix))

    def save(self, path: str | os.PathLike[str]) -> None:
        save_npz(path, self.to_arrays())

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Pose2D:
        return cls.from_arrays(_load_npz(path))


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
        out = _keypoint_arrays(self, "")
        if self.ids is not None:
            out["ids"] = self.ids
        return out

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> MultiPose2D:
        ids = np.asarray(arrays["ids"]) if "ids" in arrays else None
        return cls(**_keypoint_fields(arrays, ""), ids=ids)


def _keypoint_arrays(pose: Pose2D | MultiPose2D, prefix: str) -> dict[str, np.ndarray]:
    """The arrays Pose2D and MultiPose2D store alike (world only when present), keys `prefix`ed."""
    out = {
        f"{prefix}keypoints": pose.keypoints,
        f"{prefix}timestamps": pose.timestamps,
        f"{prefix}skeleton": np.array(pose.skeleton),
        f"{prefix}image_size": np.array(pose.image_size, dtype=np.int64),
    }
    if pose.world is not None:
        out[f"{prefix}world"] = pose.world
    return out


def _keypoint_fields(arrays: Mapping[str, np.ndarray], prefix: str) -> dict[str, Any]:
    """The constructor fields `_keypoint_arrays` stored, read back."""
    world = arrays[f"{prefix}world"] if f"{prefix}world" in arrays else None
    size = np.asarray(arrays[f"{prefix}image_size"])
    return {
        "keypoints": np.asarray(arrays[f"{prefix}keypoints"]),
        "timestamps": np.asarray(arrays[f"{prefix}timestamps"]),
        "skeleton": str(arrays[f"{prefix}skeleton"]),
        "image_size": (int(size[0]), int(size[1])),
        "world": None if world is None else np.asarray(world),
    }


# Where a Pose3D's cameras are stored: a JSON list of their tables (`Camera.to_dict`) under the
# array `<prefix>meta_calibration`, the name clip files have always used for them.
_CAMERAS_META = "calibration"


@dataclass(frozen=True, eq=False)
class Pose3D:
    """3D joints of one person over a take, in COCO-17 order.

    joints:     (T, 17, 3) float32, right-handed; metres when `units == "m"`; NaN = missing.
    confidence: (T, 17) float32 in [0, 1] (NaN where the joint is missing).
    timestamps: (T,) float64 seconds.
    frame:      name of the coordinate frame (e.g. "camera", "world", "hips").
    units:      "m", or "relative" when the lifter does not know the scale.
    cameras:    the calibrated cameras the joints were triangulated from (world frame), or None;
                the QC projects the 3D into them again.
    """

    joints: np.ndarray
    confidence: np.ndarray
    timestamps: np.ndarray
    frame: str = "camera"
    units: Units = "m"
    meta: dict[str, str] = field(default_factory=dict)
    cameras: CameraGroup | None = None

    def __post_init__(self) -> None:
        j = np.asarray(self.joints, dtype=np.float32)
        if j.ndim != 3 or j.shape[1:] != (len(COCO17), 3):
            raise InputError(f"Pose3D: joints must have shape (T, 17, 3), got {j.shape}")
        partial = np.isnan(j).any(axis=-1) & ~np.isnan(j).all(axis=-1)
        if partial.any():
            raise InputError("Pose3D: a joint has some coordinates missing but not all")
        c = np.asarray(self.confidence, dtype=np.float32)
        if c.shape != j.shape[:2]:
            raise InputError(f"Pose3D: confidence must have shape {j.shape[:2]}, got {c.shape}")
        _confidence(c, "Pose3D")
        if self.units not in ("m", "relative"):
            raise InputError(f"Pose3D: units must be 'm' or 'relative', got {self.units!r}")
        if _CAMERAS_META in self.meta:
            raise InputError(f"Pose3D: meta key {_CAMERAS_META!r} is kept for the cameras field")
        if self.cameras is not None and not isinstance(self.cameras, CameraGroup):
            object.__setattr__(self, "cameras", CameraGroup(self.cameras))
        object.__setattr__(self, "joints", j)
        object.__setattr__(self, "confidence", c)
        object.__setattr__(self, "timestamps", _timestamps(self.timestamps, len(j), "Pose3D"))

    def __len__(self) -> int:
        return len(self.joints)

    def frames(self, start: int, stop: int, *, origin_s: float = 0.0) -> Pose3D:
        """Frames [start, stop), on a clock whose 0 is `origin_s` of this one."""
        return replace(
            self,
            joints=self.joints[start:stop],
            confidence=self.confidence[start:stop],
            timestamps=self.timestamps[start:stop] - origin_s,
        )

    def joint(self, name: str) -> np.ndarray:
        """(T, 3) trajectory of one COCO-17 joint."""
        return self.joints[:, COCO17.index[name]]

    def to_arrays(self, prefix: str = "") -> dict[str, np.ndarray]:
        out = {
            f"{prefix}joints": self.joints,
            f"{prefix}confidence": self.confidence,
            f"{prefix}timestamps": self.timestamps,
            f"{prefix}frame": np.array(self.frame),
            f"{prefix}units": np.array(self.units),
        }
        for k, v in self.meta.items():
            out[f"{prefix}meta_{k}"] = np.array(v)
        if self.cameras is not None:
            out[f"{prefix}meta_{_CAMERAS_META}"] = np.array(json.dumps(self.cameras.to_tables()))
        return out

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray], prefix: str = "") -> Pose3D:
        meta_prefix = f"{prefix}meta_"
        meta = {k[len(meta_prefix) :]: str(arrays[k]) for k in arrays if k.startswith(meta_prefix)}
        tables = meta.pop(_CAMERAS_META, None)
        units = str(arrays[f"{prefix}units"])
        if units not in ("m", "relative"):
            raise InputError(f"Pose3D: units must be 'm' or 'relative', got {units!r}")
        return cls(
            joints=np.asarray(arrays[f"{prefix}joints"]),
            confidence=np.asarray(arrays[f"{prefix}confidence"]),
            timestamps=np.asarray(arrays[f"{prefix}timestamps"]),
            frame=str(arrays[f"{prefix}frame"]),
            units="m" if units == "m" else "relative",
            meta=meta,
            cameras=None if tables is None else _cameras(tables),
        )

    def save(self, path: str | os.PathLike[str]) -> None:
        save_npz(path, self.to_arrays())

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Pose3D:
        return cls.from_arrays(_load_npz(path))


def _cameras(tables: str) -> CameraGroup:
    """The cameras stored by `Pose3D.to_arrays` (a JSON list of camera tables)."""
    try:
        return CameraGroup.from_tables(json.loads(tables), source="Pose3D cameras")
    except (json.JSONDecodeError, AttributeError, TypeError) as exc:
        raise InputError(f"Pose3D: stored cameras are not camera tables ({exc})") from None


def save_npz(path: str | os.PathLike[str], arrays: Mapping[str, np.ndarray]) -> None:
    """Write arrays to a compressed .npz (object arrays refused: nothing here is ever pickled)."""
    for name, value in arrays.items():
        if value.dtype == object:
            raise InputError(f"{os.fspath(path)}: array {name!r} has dtype object")
    np.savez_compressed(path, allow_pickle=False, **arrays)


def _load_npz(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """All arrays of an .npz, never unpickling; a bad file is an InputError naming it."""
    try:
        with np.load(path, allow_pickle=False) as data:
            return {k: data[k] for k in data.files}
    except (OSError, ValueError, EOFError) as exc:
        raise InputError(f"{os.fspath(path)}: not a readable .npz file ({exc})") from None
