"""Evaluation measures of the seeds as pure functions over arrays.

Dissertation (seed 000, §3.4): RMSE (Eq. 3.11–3.12), loss L (3.15), CCA (3.16–3.17), local CCA
(3.18), LCCA_Θ (3.19), ΔLCCA (3.20), jerkiness J, J̃ and ΔJ̃ (3.21–3.22). Seed 002: forced CCA
(FCCA, Eq. 4.5–4.6). Seed 001: average position error APE (Eq. 1), speed histograms and the
Hellinger distance (Eq. 2). GENEA 2022's average acceleration and jerk (`derivative_norms`).

Angles are `(N, 11)` radians (or `(N, 11)` in [0, 1] for L); every function returns radians-based
values — conversion to degrees belongs to reports. Rows with NaN are the caller's business except
where a docstring says otherwise (L and RMSE ignore unknown ground-truth entries).

Conventions chosen where the seeds leave a gap:
- CCA is the first canonical correlation, in [0, 1]; data of rank 0 (a constant signal) has no
  correlation and gives 0. Directions with relative variance below `RANK_TOL` are discarded
  (numerically constant columns would otherwise correlate with anything).
- Local CCA of a sequence shorter than the window uses the whole sequence as its one window.
- FCCA uses the first canonical pair (a, b) only, as Eq. 4.5 writes it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

RANK_TOL = 1e-8  # singular values below RANK_TOL × the largest count as zero
CONST_TOL = 1e-9  # … and below CONST_TOL × √n × max|x| (float noise around a constant)
F64 = NDArray[np.float64]


def _2d(a: ArrayLike) -> F64:
    x = np.asarray(a, dtype=np.float64)
    return x[:, None] if x.ndim == 1 else x


def _pair(t: ArrayLike, p: ArrayLike) -> tuple[F64, F64]:
    tt, pp = _2d(t), _2d(p)
    if tt.shape != pp.shape:
        raise ValueError(f"shapes differ: {tt.shape} vs {pp.shape}")
    return tt, pp


# --------------------------------------------------------------------------------------------------
# Errors


def loss_l(true01: ArrayLike, pred01: ArrayLike) -> float:
    """Loss L (Eq. 3.15): mean squared error of normalised angles `(N, 11)` in [0, 1].

    Entries where the ground truth is NaN (unknown pose) are left out of the mean.
    """
    t, p = _pair(true01, pred01)
    ok = np.isfinite(t)
    return float(np.mean((t[ok] - p[ok]) ** 2))  # Eq. 3.15


def rmse_per_joint(true: ArrayLike, pred: ArrayLike) -> F64:
    """RMSE(θ_j) (Eq. 3.11) of `(N, J)` angles → `(J,)`, radians; NaN ground truth left out.

    NaN (without a warning) for a joint whose ground truth is never known.
    """
    t, p = _pair(true, pred)
    ok = np.isfinite(t)
    n = ok.sum(axis=0)
    sq = np.where(ok, (t - p) ** 2, 0.0).sum(axis=0)
    return np.sqrt(np.divide(sq, n, out=np.full(n.shape, np.nan), where=n > 0))  # Eq. 3.11


def rmse(true: ArrayLike, pred: ArrayLike) -> float:
    """Overall RMSE (Eq. 3.12) of `(N, J)` angles, radians; NaN ground truth left out."""
    t, p = _pair(true, pred)
    ok = np.isfinite(t)
    return float(np.sqrt(np.mean((t[ok] - p[ok]) ** 2)))  # Eq. 3.12


def ape(true: ArrayLike, pred: ArrayLike) -> float:
    """Average position error (seed 001, Eq. 1): 1/(K·T) Σ_t Σ_k ‖g_kt − ĝ_kt‖₂.

    `(T, K, D)` positions (norm over D) or `(T, K)` angles (the norm of a scalar is its absolute
    value, so on angles APE is the mean absolute error).
    """
    t, p = np.asarray(true, dtype=np.float64), np.asarray(pred, dtype=np.float64)
    if t.shape != p.shape:
        raise ValueError(f"shapes differ: {t.shape} vs {p.shape}")
    diff = t - p
    dist = np.linalg.norm(diff, axis=-1) if diff.ndim == 3 else np.abs(diff)
    return float(np.mean(dist))  # Eq. 1


# --------------------------------------------------------------------------------------------------
# Canonical correlation


def _floor(x: F64) -> F64:
    """Absolute singular-value floor of x (..., n, p): CONST_TOL × √n × max|x| per matrix."""
    n = x.shape[-2]
    return CONST_TOL * np.sqrt(n) * np.max(np.abs(x), axis=(-2, -1))


def _basis(x: F64) -> tuple[F64, F64, F64]:
    """Orthonormal basis of the centred columns of x (n, p): (Q (n, r), s (r,), V (p, r))."""
    xc = x - x.mean(axis=0)
    u, s, vt = np.linalg.svd(xc, full_matrices=False)
    top = s[0] if s.size else 0.0
    keep = (s > RANK_TOL * top) & (s > _floor(x))
    return u[:, keep], s[keep], vt[keep].T


def cca_directions(x: ArrayLike, y: ArrayLike) -> tuple[F64, F64, float]:
    """First canonical pair of `x (n, p)` and `y (n, q)` (Eq. 3.16): (a (p,), b (q,), ρ).

    ρ = max corr(x a, y b) ≥ 0; a and b are zero when either side has rank 0 (then ρ = 0).
    """
    xx, yy = _2d(x), _2d(y)
    if len(xx) != len(yy):
        raise ValueError(f"x and y need the same number of rows: {len(xx)} vs {len(yy)}")
    qx, sx, vx = _basis(xx)
    qy, sy, vy = _basis(yy)
    if qx.shape[1] == 0 or qy.shape[1] == 0:
        return np.zeros(xx.shape[1]), np.zeros(yy.shape[1]), 0.0
    u, s, wt = np.linalg.svd(qx.T @ qy)
    a = vx @ (u[:, 0] / sx)
    b = vy @ (wt[0] / sy)
    return a, b, float(min(s[0], 1.0))


def cca(x: ArrayLike, y: ArrayLike) -> float:
    """CCA(X, Y) = ρ, the first canonical correlation (Eq. 3.16–3.17)."""
    return cca_directions(x, y)[2]


def _batched_cca(xw: F64, yw: F64) -> F64:
    """First canonical correlations of windows xw (W, L, p), yw (W, L, q) → (W,)."""

    def basis(w: F64) -> F64:
        wc = w - w.mean(axis=1, keepdims=True)
        u, s, _ = np.linalg.svd(wc, full_matrices=False)
        keep = (s > RANK_TOL * s[:, :1]) & (s > _floor(w)[:, None])
        return u * keep[:, None, :]  # zero the discarded directions

    qx, qy = basis(xw), basis(yw)
    s = np.linalg.svd(np.swapaxes(qx, 1, 2) @ qy, compute_uv=False)
    return np.minimum(s[:, 0], 1.0)


def local_cca(x: ArrayLike, y: ArrayLike, *, window: int, stride: int, chunk: int = 512) -> float:
    """Local CCA (Eq. 3.18): mean CCA over sliding windows of `window` frames.

    x `(d, p)`, y `(d, q)`; windows start every `stride` frames (`train.lcca_stride`; Eq. 3.18:
    1). A sequence shorter
    than the window is one window.
    """
    return float(np.mean(local_cca_values(x, y, window=window, stride=stride, chunk=chunk)))


def local_cca_values(
    x: ArrayLike, y: ArrayLike, *, window: int, stride: int, chunk: int = 512
) -> F64:
    """The per-window CCAs whose mean is `local_cca`, `(W,)`."""
    xx, yy = _2d(x), _2d(y)
    if len(xx) != len(yy):
        raise ValueError(f"x and y need the same number of rows: {len(xx)} vs {len(yy)}")
    if window < 2 or len(xx) < 2:
        raise ValueError("local CCA needs a window and a sequence of at least 2 frames")
    n = min(window, len(xx))
    xs = np.lib.stride_tricks.sliding_window_view(xx, n, axis=0)[::stride]  # (W, p, n)
    ys = np.lib.stride_tricks.sliding_window_view(yy, n, axis=0)[::stride]
    out = [
        _batched_cca(np.swapaxes(xs[i : i + chunk], 1, 2), np.swapaxes(ys[i : i + chunk], 1, 2))
        for i in range(0, len(xs), chunk)
    ]
    return np.concatenate(out)  # the summands of Eq. 3.18


def lcca_theta(true: ArrayLike, pred: ArrayLike, *, window: int, stride: int) -> float:
    """LCCA_Θ = LCCA(ᵗΘ, ᵖΘ) (Eq. 3.19)."""
    return local_cca(true, pred, window=window, stride=stride)


def delta_lcca(
    audio: ArrayLike, true: ArrayLike, *, pred: ArrayLike, window: int, stride: int
) -> float:
    """ΔLCCA = |LCCA(Ω, ᵗΘ) − LCCA(Ω, ᵖΘ)| (Eq. 3.20)."""
    return abs(
        local_cca(audio, true, window=window, stride=stride)
        - local_cca(audio, pred, window=window, stride=stride)
    )


def fcca(true: ArrayLike, pred: ArrayLike, *, audio: ArrayLike) -> float:
    """Forced CCA ρ_f (seed 002, Eq. 4.5–4.6).

    (a, b) = argmax corr(a′X, b′Y) on the ground-truth motion X `(n, 11)` and audio Y `(n, F)`
    (Eq. 4.6); ρ_f = |corr(a′X*, b′Y)| with the predicted motion X* (Eq. 4.5). FCCA(X, X, Y)
    equals CCA(X, Y). A constant prediction has no correlation: 0.
    """
    a, b, _ = cca_directions(true, audio)  # Eq. 4.6
    if _basis(_2d(pred))[0].shape[1] == 0:
        return 0.0  # a constant prediction
    u = _2d(pred) @ a
    v = _2d(audio) @ b
    u, v = u - u.mean(), v - v.mean()
    den = float(np.sqrt((u @ u) * (v @ v)))
    if den <= 0 or not np.isfinite(den):
        return 0.0
    return abs(float(u @ v) / den)  # Eq. 4.5


# --------------------------------------------------------------------------------------------------
# Smoothness and speed distributions


def jerkiness(theta: ArrayLike, rate_hz: float) -> float:
    """Angular jerkiness J (Eq. 3.21) of `(N, 11)` radians sampled at `rate_hz`, rad² s⁻⁵.

    J = 1/(2 f (N − 3)) Σ_i Σ_j (Δ³Θ_ij)², Δ³Θ_ij = (Θ_{i+3} − 3Θ_{i+2} + 3Θ_{i+1} − Θ_i) f³.
    """
    th = _2d(theta)
    if len(th) < 4:
        raise ValueError("jerkiness needs at least 4 frames")
    d3 = np.diff(th, n=3, axis=0) * rate_hz**3  # 3rd-order forward difference
    return float(np.sum(d3**2) / (2 * rate_hz * (len(th) - 3)))  # Eq. 3.21


def delta_jerkiness(true: ArrayLike, pred: ArrayLike, *, rate_hz: float) -> float:
    """ΔJ = |J(ᵗΘ) − J(ᵖΘ)| (§3.4.4)."""
    return abs(jerkiness(true, rate_hz) - jerkiness(pred, rate_hz))


def mean_jerkiness(
    trues: Sequence[ArrayLike], preds: Sequence[ArrayLike], *, rate_hz: float
) -> tuple[float, float]:
    """(J̃, ΔJ̃) over n sequences (Eq. 3.22): J̃ of the predictions and the mean ΔJ."""
    if len(trues) != len(preds) or not trues:
        raise ValueError("need the same, non-zero number of true and predicted sequences")
    js = [jerkiness(p, rate_hz) for p in preds]
    djs = [delta_jerkiness(t, p, rate_hz=rate_hz) for t, p in zip(trues, preds, strict=True)]
    return float(np.mean(js)), float(np.mean(djs))  # Eq. 3.22


def speeds(theta: ArrayLike, rate_hz: float) -> F64:
    """Absolute speeds `(N − 1, J)` of `(N, J)` angles (rad/s) or positions, by finite difference.

    For `(N, K, D)` positions the speed is the norm of the displacement over D.
    """
    x = np.asarray(theta, dtype=np.float64)
    d = np.diff(x, axis=0) * rate_hz
    return np.linalg.norm(d, axis=-1) if x.ndim == 3 else np.abs(d)


def derivative_norms(x: ArrayLike, *, rate_hz: float, order: int) -> F64:
    """|Δⁿx| · fⁿ per frame and joint, `(N − n, J)`: speed (n = 1), acceleration (2), jerk (3).

    `(N, J)` angles (the norm of a scalar is its absolute value) or `(N, K, D)` positions (the
    norm over D), as GENEA 2022's numerical evaluations compute them (scaled by fps^n).
    """
    v = np.asarray(x, dtype=np.float64)
    if order < 1 or len(v) <= order:
        raise ValueError(f"a derivative of order {order} needs more than {order} frames")
    d = np.diff(v, n=order, axis=0) * rate_hz**order
    return np.linalg.norm(d, axis=-1) if v.ndim == 3 else np.abs(d)


def average_derivative(x: ArrayLike, *, rate_hz: float, order: int) -> float:
    """GENEA's average acceleration (order 2) or jerk (order 3): mean of `derivative_norms`."""
    return float(np.mean(derivative_norms(x, rate_hz=rate_hz, order=order)))


def speed_histogram(speed: ArrayLike, bin_width: float, *, top: float) -> F64:
    """Relative frequencies of speed values in equal-width bins [0, w), [w, 2w) … up to `top`.

    Values at or above `top` go in the last bin. Returns `(ceil(top / w),)` summing to 1 (all
    zeros for no data).
    """
    v = np.asarray(speed, dtype=np.float64).ravel()
    v = v[np.isfinite(v)]
    n_bins = int(np.ceil(top / bin_width))
    idx = np.minimum((v / bin_width).astype(np.int64), n_bins - 1)
    counts = np.bincount(idx, minlength=n_bins).astype(np.float64)
    total = counts.sum()
    return counts / total if total > 0 else counts


def hellinger(h1: ArrayLike, h2: ArrayLike) -> float:
    """Hellinger distance of two normalised histograms (seed 001, Eq. 2), in [0, 1].

    H(h¹, h²) = sqrt(1 − Σ_i sqrt(h¹_i h²_i)).
    """
    a, b = np.asarray(h1, dtype=np.float64), np.asarray(h2, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"histograms differ in shape: {a.shape} vs {b.shape}")
    bc = float(np.sum(np.sqrt(a * b)))  # Bhattacharyya coefficient
    return float(np.sqrt(max(0.0, 1.0 - bc)))  # Eq. 2
