"""Keypoint sets of the detectors and lifters we read, and their map to COCO-17.

Every skeleton names its joints with one shared vocabulary (COCO's snake_case names where the joint
is the same), so mapping between skeletons is a lookup by name, not a hand-written index table.
COCO-17 is the canonical set of Pose3D (docs/architecture.md "Contracts").
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gesturebank.errors import InputError

COCO17_JOINTS = (
    "nose",
    "left_eye",
    "right_eye",
    "left_ear",
    "right_ear",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
)

# Bones of COCO-17, for drawing and bone-length checks.
COCO17_BONES = (
    ("left_shoulder", "right_shoulder"),
    ("left_shoulder", "left_elbow"),
    ("left_elbow", "left_wrist"),
    ("right_shoulder", "right_elbow"),
    ("right_elbow", "right_wrist"),
    ("left_shoulder", "left_hip"),
    ("right_shoulder", "right_hip"),
    ("left_hip", "right_hip"),
    ("left_hip", "left_knee"),
    ("left_knee", "left_ankle"),
    ("right_hip", "right_knee"),
    ("right_knee", "right_ankle"),
    ("nose", "left_eye"),
    ("nose", "right_eye"),
    ("left_eye", "left_ear"),
    ("right_eye", "right_ear"),
)


@dataclass(frozen=True)
class Skeleton:
    """A named, ordered keypoint set."""

    name: str
    joints: tuple[str, ...]
    description: str = ""
    index: dict[str, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if len(set(self.joints)) != len(self.joints):
            raise ValueError(f"skeleton {self.name!r} repeats a joint name")
        object.__setattr__(self, "index", {j: i for i, j in enumerate(self.joints)})

    def __len__(self) -> int:
        return len(self.joints)

    def map_to(self, target: Skeleton) -> np.ndarray:
        """Source index of each target joint, −1 where this skeleton lacks it: (len(target),)."""
        return np.array([self.index.get(j, -1) for j in target.joints], dtype=np.int64)

    def convert(self, points: np.ndarray, target: Skeleton) -> np.ndarray:
        """Re-order `points (..., len(self), C)` into `(..., len(target), C)`; absent → NaN."""
        points = np.asarray(points)
        if points.shape[-2] != len(self):
            raise InputError(
                f"{self.name}: expected {len(self)} keypoints on axis -2, got shape {points.shape}"
            )
        src = self.map_to(target)
        out = np.full((*points.shape[:-2], len(target), points.shape[-1]), np.nan, dtype=np.float32)
        have = src >= 0
        out[..., have, :] = points[..., src[have], :]
        return out


COCO17 = Skeleton("coco17", COCO17_JOINTS, "COCO keypoints (17); the canonical set of Pose3D")

# Halpe-26 (rtmlib / Pose2Sim default): COCO-17 followed by head, neck, hip and feet.
HALPE26 = Skeleton(
    "halpe26",
    (
        *COCO17_JOINTS,
        "head_top",
        "neck",
        "mid_hip",
        "left_big_toe",
        "right_big_toe",
        "left_small_toe",
        "right_small_toe",
        "left_heel",
        "right_heel",
    ),
    "Halpe-26, as written by rtmlib and Pose2Sim",
)

BLAZEPOSE33 = Skeleton(
    "blazepose33",
    (
        "nose",
        "left_eye_inner",
        "left_eye",
        "left_eye_outer",
        "right_eye_inner",
        "right_eye",
        "right_eye_outer",
        "left_ear",
        "right_ear",
        "mouth_left",
        "mouth_right",
        "left_shoulder",
        "right_shoulder",
        "left_elbow",
        "right_elbow",
        "left_wrist",
        "right_wrist",
        "left_pinky",
        "right_pinky",
        "left_index",
        "right_index",
        "left_thumb",
        "right_thumb",
        "left_hip",
        "right_hip",
        "left_knee",
        "right_knee",
        "left_ankle",
        "right_ankle",
        "left_heel",
        "right_heel",
        "left_foot_index",
        "right_foot_index",
    ),
    "MediaPipe BlazePose (33 landmarks)",
)

OPENPOSE_BODY25 = Skeleton(
    "body25",
    (
        "nose",
        "neck",
        "right_shoulder",
        "right_elbow",
        "right_wrist",
        "left_shoulder",
        "left_elbow",
        "left_wrist",
        "mid_hip",
        "right_hip",
        "right_knee",
        "right_ankle",
        "left_hip",
        "left_knee",
        "left_ankle",
        "right_eye",
        "left_eye",
        "right_ear",
        "left_ear",
        "left_big_toe",
        "left_small_toe",
        "left_heel",
        "right_big_toe",
        "right_small_toe",
        "right_heel",
    ),
    "OpenPose BODY_25",
)

OPENPOSE_COCO18 = Skeleton(
    "coco18",
    (
        "nose",
        "neck",
        "right_shoulder",
        "right_elbow",
        "right_wrist",
        "left_shoulder",
        "left_elbow",
        "left_wrist",
        "right_hip",
        "right_knee",
        "right_ankle",
        "left_hip",
        "left_knee",
        "left_ankle",
        "right_eye",
        "left_eye",
        "right_ear",
        "left_ear",
    ),
    "OpenPose COCO-18 (with neck)",
)

# Human3.6M 17-joint order as used by VideoPose3D / MotionBERT. Joint 9 is the nose ("neck/nose"
# in some papers); H36M has no eyes or ears, so those COCO joints are NaN after conversion.
H36M17 = Skeleton(
    "h36m17",
    (
        "pelvis",
        "right_hip",
        "right_knee",
        "right_ankle",
        "left_hip",
        "left_knee",
        "left_ankle",
        "spine",
        "thorax",
        "nose",
        "head_top",
        "left_shoulder",
        "left_elbow",
        "left_wrist",
        "right_shoulder",
        "right_elbow",
        "right_wrist",
    ),
    "Human3.6M 17 joints (VideoPose3D order)",
)

SKELETONS: dict[str, Skeleton] = {
    s.name: s for s in (COCO17, HALPE26, BLAZEPOSE33, OPENPOSE_BODY25, OPENPOSE_COCO18, H36M17)
}


def get_skeleton(name: str) -> Skeleton:
    """The skeleton registered under `name`; InputError naming the known ones otherwise."""
    try:
        return SKELETONS[name]
    except KeyError:
        raise InputError(
            f"unknown skeleton {name!r}; known: {', '.join(sorted(SKELETONS))}"
        ) from None


def to_coco17(points: np.ndarray, skeleton: str | Skeleton) -> np.ndarray:
    """`(..., K, C)` keypoints of `skeleton` in COCO-17 order `(..., 17, C)`; absent → NaN."""
    src = skeleton if isinstance(skeleton, Skeleton) else get_skeleton(skeleton)
    return src.convert(points, COCO17)
