"""One least-squares fit of a whole triangulated take (anipose's `triangulate_optim` idea).

The robust DLT solves each point alone; here every point of the take is moved at once to
minimise, over the observations the robust step kept (labels corrected):

    Σ ρ(reprojection px, clipped at the exclusion threshold)              images
  + Σ ρ(σ_px · |acceleration| / smooth_accel)                            smooth motion
  + Σ ρ(σ_px · (|bone| − L_bone) / bone_tolerance)                       a rigid skeleton

ρ is the soft-L1 loss with scale σ_px = `_NOISE_PX` (quadratic for detector noise, linear for
outliers); clipping bounds what one wrong observation can cost. L_bone is the bone's median
length over the take from the robust DLT, so bones keep one length per take, also across
chunks. The Jacobian is sparse (a residual touches one to three points), so finite differences
with `jac_sparsity` cost a few dozen evaluations; long takes are solved in overlapping chunks
of `chunk_frames`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import coo_matrix

from gesturebank.lift.multiview.robust import Views
from gesturebank.skeletons import COCO17

log = logging.getLogger(__name__)

_I = COCO17.index
# Bones of constant length: the limbs, the torso's sides and the head (a rigid face).
BONES = tuple(
    (_I[a], _I[b])
    for a, b in (
        ("left_shoulder", "right_shoulder"),
        ("left_hip", "right_hip"),
        ("left_shoulder", "left_hip"),
        ("right_shoulder", "right_hip"),
        ("left_shoulder", "left_elbow"),
        ("left_elbow", "left_wrist"),
        ("right_shoulder", "right_elbow"),
        ("right_elbow", "right_wrist"),
        ("left_hip", "left_knee"),
        ("left_knee", "left_ankle"),
        ("right_hip", "right_knee"),
        ("right_knee", "right_ankle"),
        ("nose", "left_eye"),
        ("nose", "right_eye"),
        ("left_eye", "right_eye"),
        ("left_eye", "left_ear"),
        ("right_eye", "right_ear"),
        ("left_ear", "right_ear"),
        ("nose", "left_ear"),
        ("nose", "right_ear"),
    )
)
_NOISE_PX = 3.0  # soft-L1 scale: a detector's typical error on a 1080p person
_OVERLAP = 8  # frames each chunk shares with its neighbours (dropped from the inner ones)


@dataclass(frozen=True)
class Refinement:
    """Before/after of `refine`: median reprojection error px and the largest bone-length
    coefficient of variation, over the points refined; iterations summed over chunks."""

    error_before_px: float
    error_after_px: float
    bone_cv_before: float
    bone_cv_after: float
    iterations: int


def reprojection(points: np.ndarray, views: Views, *, used: np.ndarray) -> np.ndarray:
    """(T, J) mean pixel error of `points (T, J, 3)` over the cameras `used (C, T, J)`."""
    R, t = views.extrinsics[:, :, :3], views.extrinsics[:, :, 3]
    cam = np.einsum("cij,tkj->ctki", R, points) + t[:, None, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        diff = (cam[..., :2] / cam[..., 2:] - views.normalised) * views.focals[:, None, None]
    err = np.where(used, np.hypot(diff[..., 0], diff[..., 1]), 0.0)
    with np.errstate(invalid="ignore"):
        return np.where(used.any(0), err.sum(0) / used.sum(0), np.nan)


def _bone_cv(points: np.ndarray) -> float:
    cvs = []
    for a, b in BONES[:8]:  # the body's bones (QC's), not the face's
        length = np.linalg.norm(points[:, a] - points[:, b], axis=-1)
        length = length[np.isfinite(length)]
        if length.size > 1:
            cvs.append(length.std() / length.mean())
    return float(max(cvs)) if cvs else float("nan")


def refine(
    points: np.ndarray,
    timestamps: np.ndarray,
    *,
    views: Views,
    used: np.ndarray,
    max_error_px: float,
    smooth_accel_mps2: float,
    bone_tolerance_m: float,
    chunk_frames: int,
) -> tuple[np.ndarray, Refinement]:
    """The take's points fitted together (module docstring).

    points (T, J, 3) world metres from the robust DLT (NaN points stay NaN); timestamps (T,) s;
    views: the observations (labels corrected); used (C, T, J): the observations kept.
    Returns refined points (T, J, 3) and the before/after summary.
    """
    pts = np.asarray(points, np.float64)
    T, _J = pts.shape[:2]
    lengths = np.full(len(BONES), np.nan)
    for b, (p, q) in enumerate(BONES):
        d = np.linalg.norm(pts[:, p] - pts[:, q], axis=-1)
        if np.isfinite(d).sum() >= 3:
            lengths[b] = np.nanmedian(d)
    before = reprojection(pts, views, used=used)
    out = pts.copy()
    iterations = 0
    step = max(chunk_frames - 2 * _OVERLAP, 1)
    for start in range(0, T, step):
        lo, hi = max(0, start - _OVERLAP), min(T, start + step + _OVERLAP)
        fitted, n_iter = _fit_chunk(
            pts[lo:hi],
            np.asarray(timestamps[lo:hi], np.float64),
            Views(
                views.normalised[:, lo:hi],
                views.weights[:, lo:hi],
                views.extrinsics,
                views.focals,
            ),
            used[:, lo:hi],
            lengths,
            max_error_px=max_error_px,
            smooth_accel_mps2=smooth_accel_mps2,
            bone_tolerance_m=bone_tolerance_m,
        )
        keep = slice(start - lo, start - lo + min(step, T - start))
        out[start : start + min(step, T - start)] = fitted[keep]
        iterations += n_iter
        if start + step >= T:
            break
    after = reprojection(out, views, used=used)
    summary = Refinement(
        error_before_px=float(np.nanmedian(before)) if np.isfinite(before).any() else np.nan,
        error_after_px=float(np.nanmedian(after)) if np.isfinite(after).any() else np.nan,
        bone_cv_before=_bone_cv(pts),
        bone_cv_after=_bone_cv(out),
        iterations=iterations,
    )
    log.debug("refinement: %s", summary)
    return out, summary


def _fit_chunk(
    pts: np.ndarray,
    times: np.ndarray,
    views: Views,
    used: np.ndarray,
    lengths: np.ndarray,
    *,
    max_error_px: float,
    smooth_accel_mps2: float,
    bone_tolerance_m: float,
) -> tuple[np.ndarray, int]:
    """Least squares over one chunk's finite points (T, J, 3) → (points, iterations)."""
    T, J = pts.shape[:2]
    free = np.isfinite(pts).all(-1)
    if not free.any():
        return pts, 0
    var = np.full((T, J), -1)
    var[free] = np.arange(free.sum())
    n_var = 3 * int(free.sum())

    # Observations: (camera, frame, joint) kept by the robust step, on a free point.
    obs_c, obs_t, obs_j = np.nonzero(used & free[None])
    obs_xy = views.normalised[obs_c, obs_t, obs_j]
    obs_w = np.sqrt(np.clip(views.weights[obs_c, obs_t, obs_j], 0, None))
    obs_v = var[obs_t, obs_j]
    R = views.extrinsics[obs_c, :, :3]
    tr = views.extrinsics[obs_c, :, 3]
    f = views.focals[obs_c]

    # Acceleration triples (t−1, t, t+1) of a joint, all free, on the real (variable) clock.
    t0, jj = np.nonzero(free[:-2] & free[1:-1] & free[2:])
    acc = np.stack([var[t0, jj], var[t0 + 1, jj], var[t0 + 2, jj]], axis=1)
    dt1 = np.maximum(times[t0 + 1] - times[t0], 1e-6)
    dt2 = np.maximum(times[t0 + 2] - times[t0 + 1], 1e-6)
    # second difference coefficients so that a = c0·x0 + c1·x1 + c2·x2 (m/s²)
    coef = np.stack([2 / (dt1 * (dt1 + dt2)), -2 / (dt1 * dt2), 2 / (dt2 * (dt1 + dt2))], axis=1)
    smooth_scale = _NOISE_PX / smooth_accel_mps2

    # Bones of a frame with both ends free and a known take length.
    bone_rows = [
        (t, b) for b, (p, q) in enumerate(BONES) if np.isfinite(lengths[b])
        for t in np.flatnonzero(free[:, p] & free[:, q])
    ]  # fmt: skip
    bt = np.array([r[0] for r in bone_rows], int)
    bb = np.array([r[1] for r in bone_rows], int)
    bones = np.asarray(BONES, int).reshape(-1, 2)
    bone_v = np.stack([var[bt, bones[bb, 0]], var[bt, bones[bb, 1]]], axis=1) if bt.size else (
        np.zeros((0, 2), int)
    )  # fmt: skip
    bone_len = lengths[bb] if bt.size else np.zeros(0)
    bone_scale = _NOISE_PX / bone_tolerance_m

    def residuals(x: np.ndarray) -> np.ndarray:
        X = x.reshape(-1, 3)
        cam = np.einsum("nij,nj->ni", R, X[obs_v]) + tr
        z = np.where(cam[:, 2:] > 1e-6, cam[:, 2:], 1e-6)  # a point behind a camera: far off
        r_img = (cam[:, :2] / z - obs_xy) * f
        r_img = np.clip(r_img, -max_error_px, max_error_px) * obs_w[:, None]
        a = np.einsum("nk,nkd->nd", coef, X[acc]) * smooth_scale
        d = np.linalg.norm(X[bone_v[:, 0]] - X[bone_v[:, 1]], axis=-1) - bone_len
        return np.concatenate([r_img.ravel(), a.ravel(), d * bone_scale])

    rows, cols = [], []
    n_img = 2 * len(obs_v)
    for k in range(2):  # each image residual: the three coordinates of its point
        r = 2 * np.arange(len(obs_v)) + k
        for d in range(3):
            rows.append(r)
            cols.append(3 * obs_v + d)
    for d in range(3):  # acceleration residual d: coordinate d of its three points
        r = n_img + 3 * np.arange(len(acc)) + d
        for k in range(3):
            rows.append(r)
            cols.append(3 * acc[:, k] + d)
    n_acc = 3 * len(acc)
    for k in range(2):  # a bone: the coordinates of both ends
        r = n_img + n_acc + np.arange(len(bone_v))
        for d in range(3):
            rows.append(r)
            cols.append(3 * bone_v[:, k] + d)
    rr, cc = np.concatenate(rows), np.concatenate(cols)
    n_res = n_img + n_acc + len(bone_v)
    sparsity = coo_matrix((np.ones(rr.size), (rr, cc)), shape=(n_res, n_var)).tocsr()
    x0 = pts[free].ravel()
    fit = least_squares(
        residuals,
        x0,
        jac_sparsity=sparsity,
        loss="soft_l1",
        f_scale=_NOISE_PX,
        method="trf",
        x_scale=0.01,
        max_nfev=50,
    )
    out = pts.copy()
    out[free] = fit.x.reshape(-1, 3)
    return out, int(fit.nfev)
