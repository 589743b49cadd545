"""Repairs of one take's keypoints as plain arrays `(T, K, C)` (C = 2 or 3 coordinates), at
the video's own timestamps: the body's scale (shoulder widths), Hampel outliers in time, and gaps
filled by linear interpolation with the confidence of their weaker anchor (`gesturebank.repair`
says why and in what order).
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from gesturebank.config import RepairConfig
from gesturebank.filters import fill_gaps
from gesturebank.skeletons import Skeleton

F64 = NDArray[np.float64]
Bools = NDArray[np.bool_]

# 1 / Φ⁻¹(3/4): makes the MAD of Gaussian data an estimate of its standard deviation.
_MAD_TO_SIGMA = 1.4826
# The MAD is also floored at this many times the window's median frame-to-frame step: at the
# apex of a fast reversal the window median lags half the window's path behind, while the
# distances to it bunch up (MAD = one step at 50 fps), which would read as an outlier.
_STEP_FLOOR = 1.5


# --------------------------------------------------------------------------------------------------
# Scale and rate


def shoulder_width(*, points: np.ndarray, skeleton: Skeleton) -> float:
    """Median distance between the shoulders of `points (T, K, C)` (C = 2 or 3 coordinates), in
    the array's units; NaN when the skeleton has no shoulders or they are never both seen."""
    idx = skeleton.index
    if "left_shoulder" not in idx or "right_shoulder" not in idx:
        return float("nan")
    d = np.linalg.norm(points[:, idx["left_shoulder"]] - points[:, idx["right_shoulder"]], axis=-1)
    d = d[np.isfinite(d) & (d > 0)]
    return float(np.median(d)) if len(d) else float("nan")


def half_window(*, timestamps: np.ndarray, half_window_s: float) -> int:
    """Frames on each side of a Hampel window: round(half_window_s × fps), at least 1, with fps
    from the median interval of `timestamps (T,)` (robust to dropped frames)."""
    ts = np.asarray(timestamps, dtype=np.float64)
    if len(ts) < 2:
        return 1
    fps = 1.0 / float(np.median(np.diff(ts)))
    # half up (25 fps × 0.1 s → 3), with room for timestamps rounded in the container
    return max(1, int(np.floor(half_window_s * fps + 0.5 + 1e-6)))


# --------------------------------------------------------------------------------------------------
# Hampel filter


def _nanmedian(a: np.ndarray) -> F64:
    """Median over the last axis ignoring NaN (NaN where all are), without all-NaN warnings."""
    s = np.sort(a, axis=-1)  # NaN sorts last
    n = np.isfinite(a).sum(axis=-1)
    lo = np.take_along_axis(s, np.maximum((n - 1) // 2, 0)[..., None], axis=-1)[..., 0]
    hi = np.take_along_axis(s, np.minimum(n // 2, a.shape[-1] - 1)[..., None], axis=-1)[..., 0]
    return np.where(n > 0, (lo + hi) / 2, np.nan)


def hampel_outliers(*, points: np.ndarray, half_window: int, z: float, mad_floor: float) -> Bools:
    """(T, K) True where a keypoint of `points (T, K, C)` is a Hampel outlier in time.

    In the centred window of ±half_window frames, d = distance of each sample to the window's
    coordinate-wise median point; MAD = median of those d over the window, at least `mad_floor`
    (array units) and 1.5 × the window's median step between frames (a moving keypoint is not
    expected closer than that). Outlier: modified z-score 0.6745·d / MAD > z, i.e.
    d > z·1.4826·MAD. NaN samples are ignored; a window with fewer than half_window + 1 (and 3)
    finite samples — too few for its median to outvote an outlier — flags nothing. Near an end
    of a seen stretch the window is one-sided, so a jump within its first or last half_window
    frames reads as outliers on its shorter side.
    """
    p = np.asarray(points, dtype=np.float64)
    h = int(half_window)
    need = max(h + 1, 3)
    out = np.zeros(p.shape[:2], dtype=bool)
    if len(p) == 0:
        return out
    for k in range(p.shape[1]):  # one keypoint at a time keeps the windows small
        padded = np.pad(p[:, k], ((h, h), (0, 0)), constant_values=np.nan)
        win = sliding_window_view(padded, 2 * h + 1, axis=0)  # (T, C, W)
        centre = _nanmedian(win)  # (T, C)
        dist = np.linalg.norm(win - centre[..., None], axis=1)  # (T, W), NaN where missing
        step = _nanmedian(np.linalg.norm(np.diff(win, axis=-1), axis=1))  # (T,)
        mad = np.fmax(np.maximum(_nanmedian(dist), mad_floor), _STEP_FLOOR * step)
        d = np.linalg.norm(p[:, k] - centre, axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            score = d / (_MAD_TO_SIGMA * mad)
        out[:, k] = (np.isfinite(dist).sum(axis=-1) >= need) & (score > z)
    return out


# --------------------------------------------------------------------------------------------------
# Gaps


def fill_keypoint_gaps(
    *, points: np.ndarray, timestamps: np.ndarray, max_gap_s: float
) -> tuple[F64, Bools]:
    """Linear interpolation in time of the NaN runs of `points (T, K, C)` up to `max_gap_s`
    (the rules of `filters.fill_gaps`); returns `(points (T, K, C), filled (T, K) bool)`."""
    p = np.asarray(points, dtype=np.float64)
    missing = np.isnan(p).any(axis=-1)
    if len(p) < 2 or not missing.any():
        return p.copy(), np.zeros(missing.shape, dtype=bool)
    flat, _ = fill_gaps(p.reshape(len(p), -1), timestamps, max_gap_s=max_gap_s)
    out = np.asarray(flat, dtype=np.float64).reshape(p.shape)
    return out, np.asarray(missing & np.isfinite(out).all(axis=-1))


def _neighbour(known: Bools, *, forward: bool) -> NDArray[np.int64]:
    """(T, K) index of the nearest known sample at or before (forward) / after each one, −1 if
    there is none."""
    t = np.arange(len(known))[:, None]
    if forward:
        return np.maximum.accumulate(np.where(known, t, -1), axis=0)
    later = np.where(known, t, len(known))[::-1]
    nxt = np.minimum.accumulate(later, axis=0)[::-1]
    return np.where(nxt < len(known), nxt, -1)


def filled_confidence(*, confidence: np.ndarray, known: np.ndarray, filled: np.ndarray) -> F64:
    """`confidence (T, K)` where each `filled` sample takes the lower confidence of the nearest
    `known` samples before and after it (the one there is, at an edge)."""
    c = np.asarray(confidence, dtype=np.float64).copy()
    known = np.asarray(known, dtype=bool)
    cols = np.arange(c.shape[1])[None, :]
    anchors = []
    for forward in (True, False):
        i = _neighbour(known, forward=forward)
        anchors.append(np.where(i >= 0, c[np.maximum(i, 0), cols], np.nan))
    lowest = np.fmin(*anchors)
    c[filled] = lowest[filled]
    return c


# --------------------------------------------------------------------------------------------------
# Outliers of a take, replaced like gaps


def take_outliers(
    points: F64, timestamps: F64, *, skeleton: Skeleton, config: RepairConfig
) -> Bools:
    """(T, K) Hampel outliers of `points (T, K, C)`; none when the take has no shoulder width."""
    scale = shoulder_width(points=points, skeleton=skeleton)
    if not np.isfinite(scale):
        return np.zeros(points.shape[:2], dtype=bool)
    return hampel_outliers(
        points=points,
        half_window=half_window(timestamps=timestamps, half_window_s=config.hampel_half_window_s),
        z=config.hampel_z,
        mad_floor=config.hampel_floor * scale,
    )


def replace_outliers(
    points: F64, outliers: Bools, *, timestamps: F64, max_gap_s: float
) -> tuple[F64, Bools]:
    """`points (T, K, C)` with the outliers set missing and every gap up to max_gap_s filled;
    returns them and the (T, K) samples filled."""
    cleared = points.copy()
    cleared[outliers] = np.nan
    return fill_keypoint_gaps(points=cleared, timestamps=timestamps, max_gap_s=max_gap_s)


def refill(
    points: F64, confidence: F64, *, outliers: Bools, timestamps: F64, max_gap_s: float
) -> tuple[F64, F64, Bools]:
    """`replace_outliers` with the confidence `(T, K)` of what was filled (`filled_confidence`;
    NaN for an outlier left missing); returns points, confidence and the (T, K) gap samples
    filled (the refilled outliers not among them)."""
    known = np.isfinite(points).all(axis=-1) & ~outliers
    out, filled = replace_outliers(points, outliers, timestamps=timestamps, max_gap_s=max_gap_s)
    conf = filled_confidence(confidence=confidence, known=known, filled=filled)
    conf[outliers & ~filled] = np.nan
    return out, conf, filled & ~outliers
