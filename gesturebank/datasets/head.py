"""The head of a clip from the face where it was found (issue 40): the face mesh's head axes
(`extract.head_pose`, camera axes) put into the 3D pose's coordinates and turned into HeadPitch,
HeadYaw and head_roll against its torso (`robot.retarget.head_from_axes`); the body's face
keypoints elsewhere, as they are. Each video frame records its source (`clip.HEAD_SOURCES`).

The body's angles are not shifted to meet the face's: an offset taken from the frames where both
measured the head (the median difference) came from the faces turned furthest, where the mesh is
least sure, and made the fallback worse (test.bvh 0–6 s rendered at 60° from 30° above: head
7.8° without it, 18.4° with it; level at 60°: 7.0° against 7.7°).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gesturebank.clip import HEAD_SOURCES
from gesturebank.geometry import Camera
from gesturebank.lift.scoring import AXES
from gesturebank.poses import Pose3D
from gesturebank.robot.pepper import INDEX
from gesturebank.robot.retarget import head_from_axes

FACE, BODY = HEAD_SOURCES.index("face"), HEAD_SOURCES.index("body")
_PITCH, _YAW = INDEX["HeadPitch"], INDEX["HeadYaw"]
# A rig camera's face head along its own optical axis, against across it (`rig_head`). Tuned on
# test.bvh 0–10 s, 4 cameras over 90° (benchmarks/head_parts.py --cameras 4, the build's head
# per frame): level 6.1 → 5.7°, 30° above 6.1 → 5.0° (1: the plain average; 0.1: 6.0 / 4.6°).
RIG_DEPTH_WEIGHT = 0.25


@dataclass(frozen=True)
class FaceHead:
    """The face mesh's head over a view's T frames: axes (T, 3, 3) columns forward, left, up in
    the camera's axes (x right, y down, z away; NaN where none), residual (T,) of the fit."""

    axes: np.ndarray
    residual: np.ndarray

    def frames(self, a: int, b: int) -> FaceHead:
        return FaceHead(self.axes[a:b], self.residual[a:b])


def rig_head(
    heads: Sequence[FaceHead | None],
    *,
    times: Sequence[np.ndarray],
    offsets_s: Sequence[float] | np.ndarray,
    cameras: Sequence[Camera],
    reference: int,
    max_residual: float,
) -> FaceHead | None:
    """The face heads of a calibrated rig's cameras as one, on the reference camera's frames and
    in its axes: each camera's head axes (T_c, 3, 3) turned into the reference camera's axes
    (R_ref·R_cᵀ), taken at the camera's frame nearest each reference frame on the reference
    clock (`times[c]` − `offsets_s[c]`, as `lift.multiview.sync.align`; none past half a frame),
    and combined where one or more cameras found the face with a fit residual of at most
    `max_residual` (`retarget.head_max_fit_residual`); the residual is the largest of those
    combined. None when no camera has a face head.

    The combination is a least-squares average of the head's axes in which each camera's
    reading along its own optical axis counts RIG_DEPTH_WEIGHT as much as across it: the face
    model reads a head's turn towards or away from a camera (depth) worse than across the
    image, and another camera of the rig sees that direction across its image. The rotation
    nearest the result is the head; one camera alone gives its own head. The cameras' own heads
    differ by the face model's error in each view, which combining shrinks
    (benchmarks/head_rig.py, held out, 4 cameras: each camera 7.1–9.1°, averaged 4.8–7.7°)."""
    if all(h is None for h in heads):
        return None
    ref_t = np.asarray(times[reference], np.float64)
    ref_r = np.asarray(cameras[reference].R, np.float64)
    weights = np.zeros((len(ref_t), 3, 3))  # Σ P_c, P_c = I − (1 − w)·z_c z_cᵀ
    total = np.zeros((len(ref_t), 3, 3))  # Σ P_c · axes_c
    count = np.zeros(len(ref_t), int)
    residual = np.full(len(ref_t), np.nan)
    for head, t, offset, camera in zip(heads, times, offsets_s, cameras, strict=True):
        if head is None or len(t) == 0:
            continue
        moved = np.asarray(t, np.float64) - float(offset)
        step = float(np.median(np.diff(moved))) if len(moved) > 1 else np.inf
        k = np.clip(np.searchsorted(moved, ref_t), 1, max(1, len(moved) - 1))
        k = np.where(np.abs(moved[k - 1] - ref_t) <= np.abs(moved[k] - ref_t), k - 1, k)
        k = np.clip(k, 0, len(moved) - 1)
        near = np.abs(moved[k] - ref_t) <= step / 2 + 1e-9
        to_ref = ref_r @ np.asarray(camera.R, np.float64).T
        axes = to_ref @ np.asarray(head.axes, np.float64)[k]
        fit = np.asarray(head.residual, np.float64)[k]
        ok = near & np.isfinite(axes).all(axis=(1, 2)) & (fit <= max_residual)
        depth = to_ref[:, 2]  # the camera's optical axis in the reference camera's axes
        across = np.eye(3) - (1.0 - RIG_DEPTH_WEIGHT) * np.outer(depth, depth)
        weights[ok] += across
        total[ok] += across @ axes[ok]
        count[ok] += 1
        residual[ok] = np.fmax(residual[ok], fit[ok])
    axes = np.full(total.shape, np.nan)
    seen = count > 0
    axes[seen] = _forward_first(np.linalg.solve(weights[seen], total[seen]))
    return FaceHead(axes, residual)


def _forward_first(axes: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotations from near-rotations `axes` (columns forward, left, up) that keep
    the forward column's direction (the head's direction is what HeadPitch and HeadYaw read):
    forward normalised, left made square to it, up = forward × left."""
    forward = axes[:, :, 0] / np.linalg.norm(axes[:, :, 0], axis=1, keepdims=True)
    left = axes[:, :, 1] - forward * np.sum(forward * axes[:, :, 1], axis=1, keepdims=True)
    left /= np.linalg.norm(left, axis=1, keepdims=True)
    return np.stack([forward, left, np.cross(forward, left)], axis=2)


def in_pose_frame(axes: np.ndarray, *, pose3d: Pose3D, camera: Camera | None) -> np.ndarray | None:
    """(T, 3, 3) camera-axes head `axes` in the coordinates of `pose3d`'s joints: a lifter's
    camera-like frame (`lift.scoring.AXES`), or the world of the calibrated `camera` that saw
    them; None for a frame neither (the face head is then not used)."""
    if camera is not None and pose3d.frame == "world":
        return np.einsum("ji,tjk->tik", camera.R, axes)  # R is world → camera: Rᵀ·axes
    flip = AXES.get(pose3d.frame)
    return None if flip is None else np.asarray(flip)[None, :, None] * axes


def mix_head(
    *,
    pose3d: Pose3D,
    raw: np.ndarray,
    roll: np.ndarray,
    body_ok: np.ndarray,
    torso_ok: np.ndarray,
    face_axes: np.ndarray | None,
    face_ok: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(raw (T, 11), roll (T,), source (T,) int8) with the head from the face where `face_ok`
    and the torso is seen (`torso_ok`), else the body's where `body_ok`, else none (NaN).

    raw, roll: the body's angles and head roll (`pepper_angles`, `head_roll`); face_axes:
    (T, 3, 3) head axes in the pose's coordinates (`in_pose_frame`) or None."""
    raw = np.array(raw, np.float32)
    roll = np.array(roll, np.float32)
    source = np.where(body_ok, BODY, 0).astype(np.int8)
    if face_axes is None:
        return raw, roll, source
    face = head_from_axes(pose3d, face_axes)
    use = face_ok & torso_ok & np.isfinite(face).all(axis=1)
    if not use.any():
        return raw, roll, source
    body = np.stack([raw[:, _PITCH], raw[:, _YAW], roll], axis=1)
    raw[:, _PITCH] = np.where(use, face[:, 0], body[:, 0])
    raw[:, _YAW] = np.where(use, face[:, 1], body[:, 1])
    roll = np.where(use, face[:, 2], body[:, 2]).astype(np.float32)
    source[use] = FACE
    known = use | body_ok
    raw[~known, _PITCH] = raw[~known, _YAW] = np.nan
    roll[~known] = np.nan
    return raw, roll, source
