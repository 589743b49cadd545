"""A person as simple meshes around COCO-17 joints: tapered tubes for limbs, neck and torso,
ellipsoids for the pelvis, hands, feet, head, hair and ears.

Every part is one triangle mesh whose vertices are computed for all frames at once
(`figure_meshes`, (T, V, 3) arrays); the ray caster adds one mesh per part, so its geometry id
is the part's index in `PARTS`. Each part has a colour role that a look paints (`looks.py`).

The head is placed on the truth's own face points (the ear midpoint is its centre, eyes and
nose give its forward direction), so the face photo's eyes and nose land on the projected truth.
Sizes are an adult's, in metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gesturebank.skeletons import COCO17

SEGMENTS = 24  # around each tube or ellipsoid
RINGS = 12  # along an ellipsoid, pole to pole; per cap of a tube

# (name, colour role); the role decides the colour in a look.
PARTS: tuple[tuple[str, str], ...] = (
    ("head", "face"),
    ("nose", "face"),
    ("hair", "hair"),
    ("left_ear", "skin"),
    ("right_ear", "skin"),
    ("neck", "skin"),
    ("torso", "shirt"),
    ("pelvis", "trousers"),
    ("left_upper_arm", "upper_sleeve"),
    ("right_upper_arm", "upper_sleeve"),
    ("left_forearm", "lower_sleeve"),
    ("right_forearm", "lower_sleeve"),
    ("left_hand", "skin"),
    ("right_hand", "skin"),
    ("left_thigh", "trousers"),
    ("right_thigh", "trousers"),
    ("left_shin", "trousers"),
    ("right_shin", "trousers"),
    ("left_foot", "shoes"),
    ("right_foot", "shoes"),
)
PART_INDEX = {name: i for i, (name, _) in enumerate(PARTS)}

# Head, in its own axes (forward, up, left) from the ear midpoint: the face points of
# `mocap.names.face_model` have the eyes 0.09 m forward of the ears at their height.
HEAD_CENTRE = (0.0, 0.02, 0.0)
HEAD_RADII = (0.105, 0.12, 0.077)
HAIR_CENTRE = (-0.03, 0.035, 0.0)
HAIR_RADII = (0.105, 0.118, 0.088)
EAR_RADII = (0.022, 0.032, 0.014)
# The truth's nose tip sits 1 cm in front of the head's ellipsoid: a nose reaches it.
NOSE_RADII = (0.025, 0.022, 0.013)

# Limbs: (part, from joint, to joint, radius at from, radius at to), metres.
LIMBS = (
    ("left_upper_arm", "left_shoulder", "left_elbow", 0.055, 0.045),
    ("right_upper_arm", "right_shoulder", "right_elbow", 0.055, 0.045),
    ("left_forearm", "left_elbow", "left_wrist", 0.043, 0.033),
    ("right_forearm", "right_elbow", "right_wrist", 0.043, 0.033),
    ("left_thigh", "left_hip", "left_knee", 0.08, 0.055),
    ("right_thigh", "right_hip", "right_knee", 0.08, 0.055),
    ("left_shin", "left_knee", "left_ankle", 0.052, 0.04),
    ("right_shin", "right_knee", "right_ankle", 0.052, 0.04),
)
HAND_LENGTH, HAND_RADII = 0.17, (0.045, 0.022)  # wrist to fingertips; across, thickness
FOOT_LENGTH, FOOT_RADII = 0.2, (0.045, 0.04)


@dataclass(frozen=True)
class Mesh:
    """One part over a take: vertices (T, V, 3) float32 metres, triangles (F, 3) uint32."""

    vertices: np.ndarray
    triangles: np.ndarray


def _grid_triangles(rows: int, cols: int) -> np.ndarray:
    """Triangles of a (rows, cols) vertex grid closed around its columns."""
    r, c = np.meshgrid(np.arange(rows - 1), np.arange(cols), indexing="ij")
    a = r * cols + c
    b = r * cols + (c + 1) % cols
    below_a, below_b = a + cols, b + cols
    quads = np.stack([a, below_a, b, b, below_a, below_b], axis=-1).reshape(-1, 3)
    return quads.astype(np.uint32)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _perpendicular(axis: np.ndarray, hint: np.ndarray) -> np.ndarray:
    """(T, 3) unit vectors ⟂ `axis`, as close to `hint` as possible (another one if parallel)."""
    p = hint - np.sum(hint * axis, axis=-1, keepdims=True) * axis
    weak = np.linalg.norm(p, axis=-1) < 1e-6
    if weak.any():
        other = np.cross(axis[weak], np.array([0.0, 0.0, 1.0]))
        other[np.linalg.norm(other, axis=-1) < 1e-6] = np.array([1.0, 0.0, 0.0])
        p[weak] = other
    return _unit(p)


def ellipsoid(centre: np.ndarray, axes: np.ndarray) -> Mesh:
    """centre (T, 3), axes (T, 3, 3): rows are the semi-axes (direction × radius)."""
    lat = np.linspace(-np.pi / 2, np.pi / 2, RINGS + 1)
    lon = np.linspace(0, 2 * np.pi, SEGMENTS, endpoint=False)
    la, lo = np.meshgrid(lat, lon, indexing="ij")
    unit = np.stack([np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)], -1)
    unit = unit.reshape(-1, 3)
    vertices = centre[:, None, :] + np.einsum("vk,tkd->tvd", unit, axes)
    return Mesh(vertices.astype(np.float32), _grid_triangles(RINGS + 1, SEGMENTS))


def tube(
    start: np.ndarray,
    end: np.ndarray,
    *,
    radii_start: tuple[float, float],
    radii_end: tuple[float, float],
    width_hint: np.ndarray,
) -> Mesh:
    """A tapered tube with rounded ends from `start` to `end` (T, 3): elliptic cross-sections
    with radii (along the width direction, across it), the width direction ⟂ the axis and as
    close to `width_hint` (T, 3) as it can be."""
    axis_vec = end - start
    axis = _unit(axis_vec)
    width = _perpendicular(axis, width_hint)
    depth = np.cross(axis, width)
    lon = np.linspace(0, 2 * np.pi, SEGMENTS, endpoint=False)
    cap = np.linspace(0, np.pi / 2, RINGS // 2 + 1)
    # Rows from the start's pole to the end's pole: (fraction along, ring scale, cap offset).
    rows = [(0.0, np.cos(a), -np.sin(a)) for a in cap[::-1]]
    rows += [(1.0, np.cos(a), np.sin(a)) for a in cap]
    along = np.array([r[0] for r in rows])
    scale = np.array([r[1] for r in rows])
    bulge = np.array([r[2] for r in rows])
    rw = np.where(along == 0, radii_start[0], radii_end[0]) * scale
    rd = np.where(along == 0, radii_start[1], radii_end[1]) * scale
    cap_r = np.where(along == 0, np.mean(radii_start), np.mean(radii_end)) * bulge
    cos, sin = np.cos(lon), np.sin(lon)
    # (T, rows, segments, 3)
    centre = start[:, None, :] + along[None, :, None] * axis_vec[:, None, :]
    centre = centre + cap_r[None, :, None] * axis[:, None, :]
    ring = (rw[:, None, None] * cos[None, :, None])[None] * width[:, None, None, :]
    ring = ring + (rd[:, None, None] * sin[None, :, None])[None] * depth[:, None, None, :]
    vertices = (centre[:, :, None, :] + ring).reshape(len(start), -1, 3)
    return Mesh(vertices.astype(np.float32), _grid_triangles(len(rows), SEGMENTS))


def head_frame(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The head's centre (T, 3) (ear midpoint) and axes (T, 3, 3), rows forward, up, left,
    from the truth's ears, eyes and nose."""
    j = {name: joints[:, i] for i, name in enumerate(COCO17.joints)}
    centre = (j["left_ear"] + j["right_ear"]) / 2
    left = _unit(j["left_ear"] - j["right_ear"])
    face = (j["left_eye"] + j["right_eye"]) / 2 - centre
    forward = _perpendicular(left, face)
    up = np.cross(forward, left)  # a person's (forward, left, up) is right-handed
    return centre, np.stack([forward, up, left], axis=1)


def _in_frame(centre: np.ndarray, axes: np.ndarray, local: tuple[float, float, float]):
    return centre + np.einsum("k,tkd->td", np.asarray(local), axes)


def _scaled(axes: np.ndarray, radii: tuple[float, float, float]) -> np.ndarray:
    return axes * np.asarray(radii)[None, :, None]


def figure_meshes(joints: np.ndarray) -> list[Mesh]:
    """One mesh per entry of `PARTS` for COCO-17 `joints (T, 17, 3)` metres (all finite)."""
    j = {name: np.asarray(joints[:, i], np.float64) for i, name in enumerate(COCO17.joints)}
    meshes: dict[str, Mesh] = {}
    head_c, head_axes = head_frame(np.asarray(joints, np.float64))
    meshes["head"] = ellipsoid(
        _in_frame(head_c, head_axes, HEAD_CENTRE), _scaled(head_axes, HEAD_RADII)
    )
    meshes["hair"] = ellipsoid(
        _in_frame(head_c, head_axes, HAIR_CENTRE), _scaled(head_axes, HAIR_RADII)
    )
    nose = j["nose"] - 0.018 * head_axes[:, 0]
    meshes["nose"] = ellipsoid(nose, _scaled(head_axes, NOSE_RADII))
    for side, sign in (("left", 1.0), ("right", -1.0)):
        ear = j[f"{side}_ear"] + sign * 0.004 * head_axes[:, 2]
        meshes[f"{side}_ear"] = ellipsoid(ear, _scaled(head_axes, EAR_RADII))

    mid_shoulder = (j["left_shoulder"] + j["right_shoulder"]) / 2
    mid_hip = (j["left_hip"] + j["right_hip"]) / 2
    shoulder_width = np.linalg.norm(j["left_shoulder"] - j["right_shoulder"], axis=-1)
    hip_width = np.linalg.norm(j["left_hip"] - j["right_hip"], axis=-1)
    across = _unit(j["left_shoulder"] - j["right_shoulder"] + j["left_hip"] - j["right_hip"])
    trunk = _unit(mid_shoulder - mid_hip)
    body_forward = _unit(np.cross(across, trunk))
    neck_top = head_c - 0.06 * head_axes[:, 1]
    meshes["neck"] = tube(
        mid_shoulder - 0.02 * trunk,
        neck_top,
        radii_start=(0.055, 0.05),
        radii_end=(0.05, 0.045),
        width_hint=across,
    )
    top_w = float(np.median(shoulder_width)) / 2
    hip_w = float(np.median(hip_width)) / 2
    meshes["torso"] = tube(
        mid_hip + 0.02 * trunk,
        mid_shoulder - 0.02 * trunk,
        radii_start=(hip_w + 0.05, 0.1),
        radii_end=(max(top_w - 0.02, 0.08), 0.1),
        width_hint=across,
    )
    pelvis_axes = np.stack([across * (hip_w + 0.06), trunk * 0.11, body_forward * 0.105], axis=1)
    meshes["pelvis"] = ellipsoid(mid_hip - 0.02 * trunk, pelvis_axes)
    for part, a, b, ra, rb in LIMBS:
        meshes[part] = tube(j[a], j[b], radii_start=(ra, ra), radii_end=(rb, rb), width_hint=across)
    for side in ("left", "right"):
        forearm = _unit(j[f"{side}_wrist"] - j[f"{side}_elbow"])
        wrist = j[f"{side}_wrist"]
        meshes[f"{side}_hand"] = tube(
            wrist + 0.02 * forearm,
            wrist + (HAND_LENGTH - HAND_RADII[0]) * forearm,
            radii_start=(0.035, 0.02),
            radii_end=HAND_RADII,
            width_hint=body_forward,
        )
        shin = _unit(j[f"{side}_knee"] - j[f"{side}_ankle"])
        toe = _perpendicular(shin, body_forward)
        ankle = j[f"{side}_ankle"] - 0.04 * shin
        meshes[f"{side}_foot"] = tube(
            ankle - 0.03 * toe,
            ankle + (FOOT_LENGTH - 0.05) * toe,
            radii_start=FOOT_RADII,
            radii_end=FOOT_RADII,
            width_hint=across,
        )
    return [meshes[name] for name, _ in PARTS]
