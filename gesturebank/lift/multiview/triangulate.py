"""Confidence-weighted DLT triangulation with camera exclusion by reprojection error.

Every (frame, joint) is triangulated on its own from the cameras that saw it with enough
confidence. When the mean reprojection error of the cameras used exceeds `max_error_px`, the
worst cameras are dropped: first by trying every subset with one camera fewer, then two fewer …
(the subset with the lowest mean error wins), down to `min_cameras`. The number of subsets tried
per point is capped by `max_combinations`; past the cap each further step greedily drops the
camera with the largest error of the best subset so far, so 12 or 50 cameras stay cheap.

Points are undistorted to normalised coordinates first, so the DLT is linear and well
conditioned; reprojection errors are measured in undistorted pixels (focal × normalised error),
which differ from raw-pixel errors by the local lens magnification only (< 1 % for usual lenses).
"""

from __future__ import annotations

import itertools
import logging
import math
from dataclasses import dataclass

import numpy as np

from gesturebank.camera_files import CameraGroup
from gesturebank.errors import InputError

log = logging.getLogger(__name__)

_BATCH = 100_000  # most (subset, point) pairs solved in one vectorised call


@dataclass(frozen=True, eq=False)
class Triangulation:
    """Result of `triangulate` over C cameras and points of shape `S` (e.g. (T, J)).

    points:  (*S, 3) world coordinates; NaN where fewer than `min_cameras` saw the point.
    error:   (*S,) mean reprojection error of the cameras used, undistorted pixels (NaN if none).
    used:    (C, *S) bool, cameras the final estimate was made from.
    """

    points: np.ndarray
    error: np.ndarray
    used: np.ndarray

    @property
    def n_cameras(self) -> np.ndarray:
        """(*S,) number of cameras used."""
        return self.used.sum(axis=0)


def dlt(normalised: np.ndarray, extrinsics: np.ndarray, *, weights: np.ndarray) -> np.ndarray:
    """Weighted linear triangulation of N points from C views.

    normalised: (C, N, 2) undistorted normalised image coordinates (NaN allowed where weight 0).
    extrinsics: (C, 3, 4) `[R | t]` of each camera (world → camera).
    weights:    (C, N) ≥ 0; a view with weight 0 does not take part.
    Returns (N, 3); NaN where fewer than two views have positive weight.
    """
    xy = np.nan_to_num(np.asarray(normalised, np.float64))
    w = np.where(np.isfinite(normalised).all(axis=-1), np.asarray(weights, np.float64), 0.0)
    P = np.asarray(extrinsics, np.float64)
    # Two rows per view: x·P3 − P1 and y·P3 − P2, scaled by the view's weight → (N, 2C, 4).
    rows_x = xy[..., 0, None] * P[:, None, 2] - P[:, None, 0]
    rows_y = xy[..., 1, None] * P[:, None, 2] - P[:, None, 1]
    A = np.stack([rows_x, rows_y], axis=1) * w[:, None, :, None]  # (C, 2, N, 4)
    A = A.transpose(2, 0, 1, 3).reshape(xy.shape[1], -1, 4)
    _, _, vt = np.linalg.svd(A)
    X = vt[:, -1]
    with np.errstate(divide="ignore", invalid="ignore"):
        points = X[:, :3] / X[:, 3:]
    points[(w > 0).sum(axis=0) < 2] = np.nan
    return points


def reprojection_errors(
    points: np.ndarray, normalised: np.ndarray, *, extrinsics: np.ndarray, focals: np.ndarray
) -> np.ndarray:
    """(C, N) pixel distance between each view's observation and the reprojected point.

    points (N, 3) world; normalised (C, N, 2); extrinsics (C, 3, 4); focals (C, 2) = (fx, fy).
    A point behind a camera gets an infinite error there; a missing observation gets NaN.
    """
    P = np.asarray(extrinsics, np.float64)
    cam = np.einsum("cij,nj->cni", P[:, :, :3], points) + P[:, None, :, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        proj = cam[..., :2] / cam[..., 2:]
    diff = (proj - normalised) * np.asarray(focals, np.float64)[:, None, :]
    err = np.hypot(diff[..., 0], diff[..., 1])
    behind = (cam[..., 2] <= 0) & np.isfinite(points).all(axis=-1)
    return np.where(behind & np.isfinite(normalised).all(axis=-1), np.inf, err)


def _solve(
    normalised: np.ndarray, extrinsics: np.ndarray, focals: np.ndarray, weights: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """DLT on `weights > 0` views → points (N, 3), per-view errors (C, N), mean error (N,)."""
    points = dlt(normalised, extrinsics, weights=weights)
    errs = reprojection_errors(points, normalised, extrinsics=extrinsics, focals=focals)
    used = weights > 0
    with np.errstate(invalid="ignore"):
        mean = np.where(used, errs, 0.0).sum(axis=0) / np.maximum(used.sum(axis=0), 1)
    mean[~np.isfinite(points).all(axis=-1)] = np.nan
    return points, errs, mean


def _subsets(members: np.ndarray, keep: int) -> np.ndarray:
    """(S, C) bool masks of every `keep`-subset of the cameras marked in `members` (C,)."""
    idx = np.flatnonzero(members)
    combos = list(itertools.combinations(idx, keep))
    masks = np.zeros((len(combos), members.size), bool)
    for s, combo in enumerate(combos):
        masks[s, list(combo)] = True
    return masks


@dataclass(eq=False)
class _Search:
    """The camera-subset search over N points: the observations it solves from and the best
    estimate so far, which `_adopt` improves in place.

    normalised (C, N, 2), extrinsics (C, 3, 4), focals (C, 2), weights (C, N): the inputs;
    points (N, 3), errs (C, N), mean (N,), used (C, N): the current estimate of each point.
    """

    normalised: np.ndarray
    extrinsics: np.ndarray
    focals: np.ndarray
    weights: np.ndarray
    points: np.ndarray
    errs: np.ndarray
    mean: np.ndarray
    used: np.ndarray


def triangulate(
    pixels: np.ndarray,
    confidence: np.ndarray,
    *,
    cameras: CameraGroup,
    min_confidence: float,
    max_error_px: float,
    min_cameras: int,
    max_combinations: int,
) -> Triangulation:
    """Triangulate points seen by calibrated cameras, excluding cameras that disagree.

    pixels:     (C, *S, 2) raw (distorted) pixel coordinates; NaN = not seen.
    confidence: (C, *S) detector confidence in [0, 1]; it weights the DLT rows.
    min_confidence: observations below it are ignored.
    max_error_px: mean reprojection error above which cameras are excluded.
    min_cameras: fewest cameras a point is triangulated from (≥ 2).
    max_combinations: most camera subsets tried per point in the exhaustive search.
    (The `multiview` config fields of the same names.)
    """
    px = np.asarray(pixels, np.float64)
    conf = np.asarray(confidence, np.float64)
    C = len(cameras)
    if px.shape[0] != C or px.shape[-1] != 2 or conf.shape != px.shape[:-1]:
        raise InputError(
            f"triangulate: need pixels (C={C}, ..., 2) and confidence (C, ...), got "
            f"{px.shape} and {conf.shape}"
        )
    if min_cameras < 2:
        raise InputError(f"triangulate: min_cameras must be at least 2, got {min_cameras}")
    shape = px.shape[1:-1]
    n = math.prod(shape)
    normalised = cameras.undistort_points(px.reshape(C, n, 2), normalised=True)
    extr = np.stack([c.extrinsics for c in cameras])
    focals = np.stack([np.diag(c.K)[:2] for c in cameras])
    conf = np.nan_to_num(conf.reshape(C, n))
    valid = np.isfinite(normalised).all(axis=-1) & (conf >= min_confidence)
    weights = np.where(valid, conf, 0.0)

    points, errs, mean = _solve(normalised, extr, focals, weights)
    search = _Search(normalised, extr, focals, weights, points, errs, mean, used=valid.copy())
    todo = np.flatnonzero((mean > max_error_px) & (valid.sum(axis=0) > min_cameras))
    if todo.size:
        _exclude(
            search,
            todo,
            max_error_px=max_error_px,
            min_cameras=min_cameras,
            max_combinations=max_combinations,
        )
    lost = ~np.isfinite(search.mean)  # no two views, or behind a camera whatever the subset
    search.points[lost] = np.nan
    search.mean[lost] = np.nan
    search.used &= ~lost
    log.debug("triangulated %d points, %d needed camera exclusion", n, todo.size)
    return Triangulation(
        points=search.points.reshape(*shape, 3),
        error=search.mean.reshape(shape),
        used=search.used.reshape(C, *shape),
    )


def _exclude(
    search: _Search,
    todo: np.ndarray,
    *,
    max_error_px: float,
    min_cameras: int,
    max_combinations: int,
) -> None:
    """Bounded camera-exclusion search for the points `todo`; improves `search` in place.

    Points with the same set of valid cameras share their candidate subsets, so each group is
    solved as one batch of shape (subsets × points).
    """
    groups: dict[bytes, list[int]] = {}
    for i in todo:
        groups.setdefault(search.used[:, i].tobytes(), []).append(int(i))
    mean = search.mean
    for key, members in groups.items():
        valid = np.frombuffer(key, dtype=bool)
        idx = np.asarray(members)
        budget = max_combinations
        for keep in range(int(valid.sum()) - 1, min_cameras - 1, -1):
            idx = idx[(mean[idx] > max_error_px) | ~np.isfinite(mean[idx])]
            if idx.size == 0:
                break
            n_subsets = math.comb(int(valid.sum()), keep)
            if n_subsets <= budget:
                budget -= n_subsets
                masks = _subsets(valid, keep)  # (S, C)
            else:
                budget = 0
                # Greedy step: drop the worst camera of each point's best subset so far.
                used = search.used[:, idx]
                worst = np.where(used, search.errs[:, idx], -np.inf).argmax(axis=0)
                masks_pp = used.copy()
                masks_pp[worst, np.arange(idx.size)] = False
                for start in range(0, idx.size, _BATCH):
                    sl = slice(start, start + _BATCH)
                    _adopt(search, idx[sl], masks_pp[None, :, sl], force=True)
                continue
            # Chunks keep the (subsets × points) batch small on long takes.
            step = max(1, _BATCH // len(masks))
            for start in range(0, idx.size, step):
                _adopt(search, idx[start : start + step], masks[:, :, None], force=False)


def _adopt(search: _Search, idx: np.ndarray, masks: np.ndarray, *, force: bool) -> None:
    """Solve points `idx` with each candidate mask (S, C, n or 1); keep the best candidate per
    point when it beats the current estimate (always when `force`, the greedy step)."""
    s = search
    S, C = masks.shape[:2]
    m = np.broadcast_to(masks, (S, C, idx.size))
    w = (s.weights[:, idx][None] * m).transpose(1, 0, 2).reshape(C, S * idx.size)
    obs = np.repeat(s.normalised[:, idx][:, None], S, axis=1).reshape(C, -1, 2)
    p, e, mu = _solve(obs, s.extrinsics, s.focals, w)
    mu = np.where(np.isfinite(mu), mu, np.inf).reshape(S, idx.size)
    best = mu.argmin(axis=0)
    flat = best * idx.size + np.arange(idx.size)
    current = np.where(np.isnan(s.mean[idx]), np.inf, s.mean[idx])
    better = force | (mu[best, np.arange(idx.size)] < current)
    take = idx[better]
    s.points[take] = p[flat[better]]
    s.errs[:, take] = e[:, flat[better]]
    s.mean[take] = mu[best, np.arange(idx.size)][better]
    s.used[:, take] = m[best[better], :, np.flatnonzero(better)].T
