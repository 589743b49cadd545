"""A person's COCO-17 3D joints as a BVH file (the clip's pose, for Blender and other viewers).

The joints are positions, not a rigged skeleton with fixed bones (a lifted pose's bone lengths
vary from frame to frame), so every joint carries three position channels holding its offset
from its parent in that frame, as Blender's rig exports do; the rotations are left out. Reading
the file back gives the same joint positions. Hierarchy: pelvis (mid-hips, the root) → hips →
knees → ankles; pelvis → neck (mid-shoulders) → shoulders → elbows → wrists; neck → nose →
eyes → ears. Joint names are COCO-17's (the name table maps them back).

A joint missing in some frames keeps its median offset from its parent there; joints missing
in every frame (legs out of the picture) are left out with the joints below them.
"""

from __future__ import annotations

import numpy as np

from gesturebank.errors import InputError
from gesturebank.mocap.bvh import Motion
from gesturebank.skeletons import COCO17

CM = 100.0  # centimetres, the unit most BVH files use
POSITION = ("Xposition", "Yposition", "Zposition")
ROOT_CHANNELS = (*POSITION, "Zrotation", "Xrotation", "Yrotation")
# (joint, parent) in file order; pelvis and neck are midpoints of COCO-17 joints
TREE = (
    ("pelvis", ""),
    ("left_hip", "pelvis"),
    ("left_knee", "left_hip"),
    ("left_ankle", "left_knee"),
    ("right_hip", "pelvis"),
    ("right_knee", "right_hip"),
    ("right_ankle", "right_knee"),
    ("neck", "pelvis"),
    ("left_shoulder", "neck"),
    ("left_elbow", "left_shoulder"),
    ("left_wrist", "left_elbow"),
    ("right_shoulder", "neck"),
    ("right_elbow", "right_shoulder"),
    ("right_wrist", "right_elbow"),
    ("nose", "neck"),
    ("left_eye", "nose"),
    ("left_ear", "left_eye"),
    ("right_eye", "nose"),
    ("right_ear", "right_eye"),
)


def _points(joints: np.ndarray) -> dict[str, np.ndarray]:
    i = COCO17.index
    out = {name: joints[:, i[name]] for name in COCO17.joints}
    out["pelvis"] = (joints[:, i["left_hip"]] + joints[:, i["right_hip"]]) / 2
    out["neck"] = (joints[:, i["left_shoulder"]] + joints[:, i["right_shoulder"]]) / 2
    return out


def person_motion(*, joints: np.ndarray, frame_time: float) -> Motion:
    """The Motion of COCO-17 `joints (T, 17, 3)` metres (NaN = missing) every `frame_time` s,
    in the joints' own axes (see `gesturebank.cli.export.upright` for a y-up, z-forward view)."""
    j = np.asarray(joints, dtype=np.float64)
    if j.ndim != 3 or j.shape[1:] != (len(COCO17), 3) or not len(j):
        raise InputError(f"person BVH: joints must have shape (T, 17, 3), got {j.shape}")
    pts = _points(j)
    names: list[str] = []
    parents: list[int] = []
    offsets: list[np.ndarray] = []
    columns: list[np.ndarray] = []
    index: dict[str, int] = {}
    for name, parent in TREE:
        if parent and parent not in index:
            continue  # below a joint left out
        local = pts[name] - pts[parent] if parent else pts[name]
        ok: np.ndarray = np.isfinite(local).all(axis=1)
        if not ok.any():
            if not parent:
                raise InputError("person BVH: the hips are missing in every frame")
            continue
        rest = np.median(local[ok], axis=0)
        local = np.where(ok[:, None], local, rest)
        index[name] = len(names)
        names.append(name)
        parents.append(index[parent] if parent else -1)
        offsets.append(rest * CM)
        columns.append(local * CM)
        if not parent:
            columns.append(np.zeros_like(local))  # the root's rotation channels
    children = set(parents)
    leaves = [k for k in range(len(names)) if k not in children]
    chans: list[tuple[str, ...]] = [ROOT_CHANNELS if p < 0 else POSITION for p in parents]
    ends = [False] * len(names)
    for k in leaves:  # BVH ends every branch with an End Site
        names.append(f"{names[k]}_End")
        parents.append(k)
        offsets.append(np.zeros(3))
        chans.append(())
        ends.append(True)
    return Motion(
        tuple(names),
        tuple(parents),
        np.array(offsets),
        tuple(chans),
        tuple(ends),
        np.concatenate(columns, axis=1),
        frame_time,
    )
