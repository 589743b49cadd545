"""A BVH motion as a Pose3D: its unit decided, joints mapped to COCO-17, face points placed.

Units: BVH has no unit field. With `mocap.units = "auto"` the scale is chosen among m, cm and mm
as the one that makes the skeleton's span (the longest path between two joints through the
hierarchy, offsets only: head to toe or hand to hand, about a person's height whatever the rest
pose) closest to 1.7 m on a log scale. Inches are not guessed (a small person in cm would look
like inches); set them explicitly.

Axes are kept as the file has them (BVH is right-handed; most files are y-up, as Blender, CMU,
LAFAN1 and gesturebank's own exports). Retargeting needs nothing more: it is invariant to any
rotation of the input.

Face: BVH skeletons end at a head joint. The nose, eyes and ears are placed on it with the face
model of the name table, in the body's rest-pose axes: with every channel at 0 every joint's
global rotation is the identity, so the rest pose's forward / up / left directions are also the
head joint's own axes, and the head's rotation in each frame carries them.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from gesturebank.config import MocapConfig
from gesturebank.errors import InputError
from gesturebank.geometry import body_frame, frame_from, torso_vectors
from gesturebank.mocap.bvh import Motion, forward_kinematics, rest_positions
from gesturebank.mocap.names import FACE, face_model, map_joints
from gesturebank.poses import Pose3D
from gesturebank.skeletons import COCO17

UNIT_M = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254}
PERSON_M = 1.7  # a person's height, what the span of a skeleton is compared with


def span(motion: Motion) -> float:
    """Longest path between two joints through the hierarchy (offset lengths), file units."""
    length = np.linalg.norm(motion.offsets, axis=1)
    down = np.zeros(len(motion.names))  # longest path from a joint down to a leaf below it
    best = 0.0
    for j in range(len(motion.names) - 1, -1, -1):
        p = motion.parents[j]
        if p >= 0:
            through = down[j] + length[j]
            best = max(best, down[p] + through)  # two branches meeting at p
            down[p] = max(down[p], through)
    return float(max(best, down.max(initial=0.0)))


def unit_scale(motion: Motion, units: str, *, source: str = "BVH") -> float:
    """Metres per file unit: `units` given, or decided from the skeleton's span ("auto")."""
    if units != "auto":
        return UNIT_M[units]
    size = span(motion)
    if not size > 0:
        raise InputError(
            f"{source}: every offset is 0, so the unit cannot be told; set mocap.units"
        )
    guesses = ("m", "cm", "mm")
    return UNIT_M[min(guesses, key=lambda u: abs(np.log(size * UNIT_M[u] / PERSON_M)))]


def _rest_axes(rest: np.ndarray, at: Mapping[str, int]) -> np.ndarray:
    """(3, 3) rows forward, up, left of the rest pose (the body frame, right-handed)."""
    forward, left, up = body_frame(
        rest[at["left_shoulder"]],
        rest[at["right_shoulder"]],
        left_hip=rest[at["left_hip"]],
        right_hip=rest[at["right_hip"]],
    )
    return np.stack([forward, up, left])


def body_axes(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The mean forward, left and up unit vectors (3,) of COCO-17 `joints (T, 17, 3)` over the
    frames that have both shoulders and hips (up: mid-hips → mid-shoulders; left: right → left
    shoulder, made orthogonal to up; forward = left × up, right-handed)."""
    j = np.asarray(joints, dtype=np.float64)
    i = COCO17.index
    across, up = torso_vectors(
        j[:, i["left_shoulder"]],
        j[:, i["right_shoulder"]],
        left_hip=j[:, i["left_hip"]],
        right_hip=j[:, i["right_hip"]],
    )
    ok = np.isfinite(up).all(axis=1) & np.isfinite(across).all(axis=1)
    if not ok.any():
        raise InputError("pose: no frame has both shoulders and both hips")
    return frame_from(across[ok].mean(axis=0), up[ok].mean(axis=0))


def motion_pose(
    motion: Motion, *, config: MocapConfig | None = None, source: str = "BVH"
) -> tuple[Pose3D, dict[str, str]]:
    """The Pose3D (COCO-17, metres, the file's axes, frame "mocap") of `motion`, and which BVH
    joint stands for each point. InputError naming `source` for an unknown skeleton."""
    config = config or MocapConfig()
    at = map_joints(motion.names, extra=config.names, source=source)
    scale = unit_scale(motion, config.units, source=source)
    pos, rot = forward_kinematics(motion)
    pos *= scale
    rest = rest_positions(motion) * scale
    axes = _rest_axes(rest, at)
    if not np.all(np.isfinite(axes)):
        raise InputError(
            f"{source}: shoulders and hips coincide in the rest pose; cannot place the face"
        )
    t = len(motion)
    has_face = all(p in at for p in FACE)  # the file's own face points come first
    joints = np.full((t, len(COCO17), 3), np.nan)
    for point, j in at.items():
        if point != "head" and (has_face or point not in FACE):
            joints[:, COCO17.index[point]] = pos[:, j]
    model = {} if has_face else face_model()
    for point, (fwd, up, left) in model.items():
        head = at["head"]
        local = fwd * axes[0] + up * axes[1] + left * axes[2]
        joints[:, COCO17.index[point]] = pos[:, head] + np.einsum("tij,j->ti", rot[:, head], local)
    confidence = np.where(np.isfinite(joints[..., 0]), 1.0, np.nan)
    pose = Pose3D(
        joints.astype(np.float32),
        confidence.astype(np.float32),
        motion.times,
        frame="mocap",
        units="m",
        meta={"source": "bvh", "metres_per_unit": f"{scale:g}"},
    )
    return pose, {point: motion.names[j] for point, j in at.items()}
