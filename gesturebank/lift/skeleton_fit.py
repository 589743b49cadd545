"""The skeleton and the least-squares problem of the `fitted` lifter (see fitted.py).

A 12-bone upper-body skeleton hangs from the neck (mid-shoulders): joints = neck + S @ bones.
`FitProblem` holds one chunk of frames: reprojection under a pinhole camera, the prior's bone
directions, a gauge term on the direction vectors, temporal smoothness, and optionally the take's
bone lengths as 12 more parameters; residuals and an analytic sparse Jacobian, vectorised over
the frames. `solve` runs `scipy.optimize.least_squares` on it.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from gesturebank.skeletons import COCO17

N_JOINTS = 13  # COCO-17 nose … right_hip: the upper body
N_BONES = 12
_LSMR_ITERATIONS = 100  # an inexact step per iteration is enough and much cheaper
_GAUGE = 100.0  # holds direction vectors near unit length; pixel-sized: lsmr well conditioned

# joints (13) = neck + S @ bone vectors (12): each joint's signed path from the neck (module doc).
# Bones: 0 half shoulder width (left), 1 spine (neck → mid-hip), 2 half hip width (left),
# 3/4 left upper arm / forearm, 5/6 right, 7 neck → nose, 8/9 nose → left/right eye,
# 10/11 left/right eye → ear.
_PATHS = {
    "nose": {7: 1},
    "left_eye": {7: 1, 8: 1},
    "right_eye": {7: 1, 9: 1},
    "left_ear": {7: 1, 8: 1, 10: 1},
    "right_ear": {7: 1, 9: 1, 11: 1},
    "left_shoulder": {0: 1},
    "right_shoulder": {0: -1},
    "left_elbow": {0: 1, 3: 1},
    "right_elbow": {0: -1, 5: 1},
    "left_wrist": {0: 1, 3: 1, 4: 1},
    "right_wrist": {0: -1, 5: 1, 6: 1},
    "left_hip": {1: 1, 2: 1},
    "right_hip": {1: 1, 2: -1},
}
S = np.zeros((N_JOINTS, N_BONES))
for _name, _path in _PATHS.items():
    for _b, _s in _path.items():
        S[COCO17.index[_name], _b] = _s
# [neck; bones] = _TO_BONES @ joints: the inverse of joints = neck + S @ bones.
_TO_BONES = np.linalg.inv(np.hstack([np.ones((N_JOINTS, 1)), S]))
# Left/right pairs of bones, whose lengths are averaged.
_PAIRS = ((3, 5), (4, 6), (8, 9), (10, 11))


def bone_vectors(joints: np.ndarray) -> np.ndarray:
    """(T, 12, 3) bone vectors of upper-body joints (T, 13 or 17, 3) in COCO-17 order."""
    return np.asarray(np.einsum("bj,tjk->tbk", _TO_BONES[1:], joints[:, :N_JOINTS]))


def skeleton_joints(neck: np.ndarray, bones: np.ndarray) -> np.ndarray:
    """(T, 13, 3) joints from the neck (T, 3) and bone vectors (T, 12, 3)."""
    return np.asarray(neck[:, None] + np.einsum("jb,tbk->tjk", S, bones))


def take_lengths(bones: np.ndarray) -> np.ndarray:
    """(12,) bone lengths over a take: the median of each (T, 12, 3) bone's length, left and
    right sides averaged (a body is symmetric; it halves the prior's noise)."""
    length = np.linalg.norm(bones, axis=-1)
    med = np.array([np.nanmedian(c) if np.isfinite(c).any() else np.nan for c in length.T])
    for a, b in _PAIRS:
        med[a] = med[b] = np.nanmean(med[[a, b]])
    return med


def ray_rotations(pixels: np.ndarray, focal: np.ndarray, *, center: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations turning the optical axis onto the ray through `pixels` (T, 2)."""
    ray = np.concatenate([(pixels - center) / focal, np.ones((len(pixels), 1))], axis=1)
    ray /= np.linalg.norm(ray, axis=1, keepdims=True)
    axis = np.cross([0.0, 0.0, 1.0], ray)
    angle = np.arccos(np.clip(ray[:, 2], -1, 1))
    norm = np.linalg.norm(axis, axis=1, keepdims=True)
    rotvec = np.where(norm > 1e-12, axis / np.maximum(norm, 1e-12), 0.0) * angle[:, None]
    return np.asarray(Rotation.from_rotvec(rotvec).as_matrix())


def second_difference(t: np.ndarray) -> np.ndarray:
    """(T-2, 3) weights of frames t-1, t, t+1 in the acceleration at t on timestamps t (T,)."""
    h1, h2 = np.diff(t)[:-1], np.diff(t)[1:]
    return np.stack([2 / (h1 * (h1 + h2)), -2 / (h1 * h2), 2 / (h2 * (h1 + h2))], axis=1)


@dataclass(frozen=True, eq=False)
class FitProblem:
    """One chunk's least-squares problem; arrays over its T frames.

    observed (T, 13, 2) ideal pixels (0 where missing); weight (T, 13) √confidence or 0;
    prior (T, 12, 3) unit directions; prior_weight (T, 12); lengths (12,); focal, center (2,);
    accel (T-2, 3) second-difference weights; smoothness: weight of the acceleration.
    length_weight: None = the lengths are fixed; else they are 12 more parameters (after the
    frames'), held to `lengths` by this weight per unit of relative change — it also fixes the
    overall scale, which one view cannot see.
    Parameters x: (T, 13, 3) flattened — row 0 the neck, rows 1… the bones' direction vectors.
    """

    observed: np.ndarray
    weight: np.ndarray
    prior: np.ndarray
    prior_weight: np.ndarray
    lengths: np.ndarray
    focal: np.ndarray
    center: np.ndarray
    accel: np.ndarray
    smoothness: float
    length_weight: float | None = None

    def _state(self, x: np.ndarray) -> tuple[np.ndarray, ...]:
        T = len(self.observed)
        p = x[: T * N_JOINTS * 3].reshape(T, N_JOINTS, 3)
        lengths = self.lengths if self.length_weight is None else x[T * N_JOINTS * 3 :]
        v = p[:, 1:]
        n = np.linalg.norm(v, axis=-1, keepdims=True)
        u = v / n
        y = np.concatenate([p[:, :1], lengths[None, :, None] * u], axis=1)  # neck, bones
        joints = skeleton_joints(y[:, 0], y[:, 1:])
        return u, n[..., 0], y, joints, lengths

    def residuals(self, x: np.ndarray) -> np.ndarray:
        u, n, y, joints, lengths = self._state(x)
        z = joints[..., 2:]
        proj = self.focal * joints[..., :2] / z + self.center
        smooth = np.einsum("to,tojk->tjk", self.accel, _windows(y))
        parts = [
            (self.weight[..., None] * (proj - self.observed)).ravel(),
            (self.prior_weight[..., None] * (u - self.prior)).ravel(),
            (_GAUGE * (n - 1)).ravel(),
            (self.smoothness * smooth).ravel(),
        ]
        if self.length_weight is not None:
            parts.append(self.length_weight * (lengths / self.lengths - 1))
        return np.concatenate(parts)

    def jacobian(self, x: np.ndarray) -> sparse.csr_matrix:
        u, n, _, joints, lengths = self._state(x)
        T = len(self.observed)
        eye = np.broadcast_to(np.eye(3), (T, 1, 3, 3))
        # d u / d v = (I − u uᵀ) / |v|; d bone / d v = length × that.
        du = (np.eye(3) - u[..., :, None] * u[..., None, :]) / n[..., None, None]
        dy = np.concatenate([eye, lengths[None, :, None, None] * du], axis=1)  # (T, 13, 3, 3)
        X, Y, Z = joints[..., 0], joints[..., 1], joints[..., 2]
        g = np.zeros((T, N_JOINTS, 2, 3))  # d pixel / d joint
        g[..., 0, 0], g[..., 0, 2] = self.focal[0] / Z, -self.focal[0] * X / Z**2
        g[..., 1, 1], g[..., 1, 2] = self.focal[1] / Z, -self.focal[1] * Y / Z**2
        s = _pattern(T)
        sign = _SIGN[None, :, None, None]
        reproj = self.weight[:, _PJ, None, None] * sign * (g[:, _PJ] @ dy[:, _PP])
        prior = self.prior_weight[..., None, None] * du
        gauge = _GAUGE * np.broadcast_to(u, (T, N_BONES, 3))
        smooth = self.smoothness * self.accel[:, :, None, None, None] * _windows(dy)
        data = np.concatenate([reproj.ravel(), prior.ravel(), gauge.ravel(), smooth.ravel()])
        n_cols = T * N_JOINTS * 3
        if self.length_weight is None:
            return sparse.csr_matrix((data, (s.rows, s.cols)), shape=(s.n_rows, n_cols))
        frames = sparse.csr_matrix((data, (s.rows, s.cols)), shape=(s.n_rows + N_BONES, n_cols))
        return sparse.hstack([frames, self._length_columns(u, g, s.n_rows)], format="csr")

    def _length_columns(self, u: np.ndarray, g: np.ndarray, n_rows: int) -> sparse.csr_matrix:
        """(rows, 12) derivatives by the lengths: d joint / d length = ± the bone's direction."""
        T = len(self.observed)
        bone = _PP > 0
        pj, pb = _PJ[bone], _PP[bone] - 1
        reproj = (self.weight[:, pj, None] * _SIGN[bone, None]) * np.einsum(
            "tpak,tpk->tpa", g[:, pj], u[:, pb]
        )  # (T, P, 2)
        t = np.arange(T)[:, None, None]
        reproj_r = (t * N_JOINTS + pj[None, :, None]) * 2 + np.arange(2)
        smooth = self.smoothness * np.einsum("to,tobk->tbk", self.accel, _windows(u))
        ts = np.arange(max(T - 2, 0))[:, None, None]
        r3 = T * (N_JOINTS * 2 + N_BONES * 4)
        smooth_r = r3 + (ts * N_JOINTS + 1 + np.arange(N_BONES)[:, None]) * 3 + np.arange(3)
        rows = [reproj_r, smooth_r, n_rows + np.arange(N_BONES)]
        cols = [
            np.broadcast_to(pb[None, :, None], reproj_r.shape),
            np.broadcast_to(np.arange(N_BONES)[:, None], smooth_r.shape),
            np.arange(N_BONES),
        ]
        data = [reproj, smooth, np.asarray(self.length_weight) / self.lengths]
        flat = [np.concatenate([a.ravel() for a in part]) for part in (data, rows, cols)]
        return sparse.csr_matrix((flat[0], (flat[1], flat[2])), shape=(n_rows + N_BONES, N_BONES))


def _windows(a: np.ndarray) -> np.ndarray:
    """(T-2, 3, ...) frames t-1, t, t+1 of a (T, ...) array, for every interior t."""
    return np.stack([a[:-2], a[1:-1], a[2:]], axis=1)


# (joint, parameter row) pairs of the reprojection Jacobian: the neck and every bone on the path.
_PJ = np.array([j for j in range(N_JOINTS) for p in range(N_BONES + 1) if p == 0 or S[j, p - 1]])
_PP = np.array([p for j in range(N_JOINTS) for p in range(N_BONES + 1) if p == 0 or S[j, p - 1]])
_SIGN = np.array([1.0 if p == 0 else S[j, p - 1] for j, p in zip(_PJ, _PP, strict=True)])


@dataclass(frozen=True)
class _Pattern:
    rows: np.ndarray
    cols: np.ndarray
    n_rows: int


@functools.lru_cache(maxsize=8)
def _pattern(T: int) -> _Pattern:
    """Row and column of every Jacobian entry, in the order `FitProblem.jacobian` fills them."""
    t = np.arange(T)[:, None, None, None]
    k = np.arange(3)
    col = lambda tt, p, kk: (tt * N_JOINTS + p) * 3 + kk  # noqa: E731 — the parameter index
    reproj_r = (t * N_JOINTS + _PJ[None, :, None, None]) * 2 + np.arange(2)[:, None]
    reproj_c = col(t, _PP[None, :, None, None], k)
    b = np.arange(N_BONES)[None, :, None, None]
    r1 = T * N_JOINTS * 2
    prior_r = r1 + (t * N_BONES + b) * 3 + k[:, None]
    prior_c = col(t, 1 + b, k)
    r2 = r1 + T * N_BONES * 3
    tb = np.arange(T)[:, None, None]
    gauge_r = r2 + tb * N_BONES + np.arange(N_BONES)[:, None] + 0 * k
    gauge_c = col(tb, 1 + np.arange(N_BONES)[:, None], k)
    r3 = r2 + T * N_BONES
    ts = np.arange(max(T - 2, 0))[:, None, None, None, None]
    o = np.arange(3)[:, None, None, None]
    q = np.arange(N_JOINTS)[:, None, None]
    smooth_r = r3 + (ts * N_JOINTS + q) * 3 + k[:, None] + 0 * o
    smooth_c = col(ts + o, q, k)
    parts = [(reproj_r, reproj_c), (prior_r, prior_c), (gauge_r, gauge_c), (smooth_r, smooth_c)]
    rows = np.concatenate([np.broadcast_arrays(r, c)[0].ravel() for r, c in parts])
    cols = np.concatenate([np.broadcast_arrays(r, c)[1].ravel() for r, c in parts])
    return _Pattern(rows, cols, r3 + max(T - 2, 0) * N_JOINTS * 3)


def solve(problem: FitProblem, x0: np.ndarray) -> np.ndarray:
    """Fitted parameters (flat, as `FitProblem` lays them out) from the start x0."""
    fit = least_squares(
        problem.residuals,
        x0,
        jac=problem.jacobian,
        method="trf",
        tr_solver="lsmr",
        # Sub-pixel is enough: tight tolerances only polish sloppy modes at many times the cost.
        ftol=1e-3,
        xtol=1e-4,
        gtol=1e-4,
        max_nfev=100,
        tr_options={"maxiter": _LSMR_ITERATIONS},
    )
    return np.asarray(fit.x)
