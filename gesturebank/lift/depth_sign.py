"""Depth-sign decoding: each bone's two readings of one 2D pose, and the path through them.

Seen by a pinhole camera, a bone of known length from a known 3D parent joint ends on the ray
through its child's pixel where that ray meets the sphere of the bone's length around the parent:
two points, `near` (towards the camera) and `far`, which coincide when the bone lies in the image
plane (Taylor, CVPR 2000; under perspective the tie is broken only weakly). `ray_candidates`
gives both. A chain of n bones has 2^n readings per frame.

`decode_path` picks one reading per frame over a whole take (a Viterbi path, second order):
a reading's own cost (anatomy, the detector's depth) plus what moving between readings costs —
the joints' velocity (|Δx| / (speed·dt))² and acceleration (|Δ²x| / (accel·dt²))². Switching
sign between two frames costs nothing where the two readings nearly coincide (the bone in the
image plane) and a lot where they are far apart, and a bone swinging through the image plane
keeps going rather than bouncing back (the acceleration term). `torso_frame` and the anatomical
costs (`elbow_fold_cost`, `behind_cost`, `inside_torso_cost`) are the readings' own costs.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import median_filter


def rays(pixels: np.ndarray, focal: np.ndarray, *, center: np.ndarray) -> np.ndarray:
    """(..., 3) unit rays through ideal pinhole `pixels` (..., 2); NaN stays NaN."""
    xy = (np.asarray(pixels, np.float64) - center) / focal
    r = np.concatenate([xy, np.ones((*xy.shape[:-1], 1))], axis=-1)
    return np.asarray(r / np.linalg.norm(r, axis=-1, keepdims=True))


def ray_candidates(
    parent: np.ndarray, ray: np.ndarray, *, length: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(near, far) child positions (..., 3): on the unit `ray` (..., 3) from the camera centre,
    `length` from `parent` (..., 3). Where the ray misses that sphere (the 2D bone is longer than
    the bone), both are the ray's point nearest the parent."""
    along = np.sum(parent * ray, axis=-1)
    disc = along**2 - np.sum(parent * parent, axis=-1) + np.asarray(length) ** 2
    root = np.sqrt(np.clip(disc, 0.0, None))
    return (along - root)[..., None] * ray, (along + root)[..., None] * ray


def depth_readings(
    parent: np.ndarray, ray: np.ndarray, *, length: float, levels: int, length_sd: float
) -> tuple[np.ndarray, np.ndarray]:
    """(T, S, 3) child positions on the unit `ray` (T, 3) that a bone of `length` from `parent`
    (T, 3) may reach, and (T, S) what each costs: with 2 `levels`, the exact `near` and `far`
    readings (cost 0); with more, S evenly spaced points along the ray within `length` of the
    ray's point nearest the parent, each costing its bone length's deviation from `length` in
    units of `length_sd` × length, squared — so a bone near the image plane, whose exact depth
    a small error of its length changes a lot, is not forced off it."""
    if levels == 2:
        near, far = ray_candidates(parent, ray, length=length)
        return np.stack([near, far], axis=1), np.zeros((len(parent), 2))
    along = np.sum(parent * ray, axis=-1)
    miss = np.sum(parent * parent, axis=-1) - along**2  # squared distance of the ray from parent
    offsets = np.linspace(-1.0, 1.0, levels) * length
    depth = along[:, None] + offsets[None, :]
    implied = np.sqrt(np.clip(miss, 0.0, None)[:, None] + offsets[None, :] ** 2)
    cost = ((implied - length) / (length_sd * length)) ** 2
    return depth[..., None] * ray[:, None, :], cost


def torso_frame(
    left_shoulder: np.ndarray, right_shoulder: np.ndarray, *, mid_hip: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(forward, left, up) unit vectors (..., 3) of a torso (retargeting's body frame: up =
    mid-hip → mid-shoulders, left ⟂ up, forward = left × up; right-handed input)."""
    neck = (left_shoulder + right_shoulder) / 2
    up = neck - mid_hip
    up = up / np.linalg.norm(up, axis=-1, keepdims=True)
    left = left_shoulder - right_shoulder
    left = left - np.sum(left * up, -1, keepdims=True) * up
    left = left / np.linalg.norm(left, axis=-1, keepdims=True)
    return np.cross(left, up), left, up


def _cos(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.asarray(
        np.sum(a * b, -1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1) + 1e-12)
    )


def elbow_fold_cost(upper: np.ndarray, fore: np.ndarray, *, max_bend_deg: float) -> np.ndarray:
    """(...,) how far the elbow bends past `max_bend_deg` (the forearm folded back onto the upper
    arm), as a cosine: 0 inside the range."""
    return np.clip(np.cos(np.deg2rad(max_bend_deg)) - _cos(upper, fore), 0.0, None)


def behind_cost(vector: np.ndarray, forward: np.ndarray, *, limit: float) -> np.ndarray:
    """(...,) how far a bone points behind the torso beyond `limit` (its unit vector's backward
    component): a shoulder reaches only so far back."""
    return np.clip(-_cos(vector, forward) - limit, 0.0, None)


def inside_torso_cost(
    point: np.ndarray,
    neck: np.ndarray,
    *,
    frame: tuple[np.ndarray, np.ndarray, np.ndarray],
    half_width: float,
    height: float,
    half_depth: float,
) -> np.ndarray:
    """(...,) how deep `point` (..., 3) lies inside the torso, a box hanging from `neck` of
    `half_width` sideways, `height` down and `half_depth` each way front to back (metres, the
    depth it would have to move to leave through the front or back); 0 outside."""
    rel = point - neck
    forward, left, up = frame
    x, y, z = np.sum(rel * forward, -1), np.sum(rel * left, -1), np.sum(rel * up, -1)
    inside = (np.abs(y) < half_width) & (z < 0) & (z > -height)
    return np.where(inside, np.clip(half_depth - np.abs(x), 0.0, None), 0.0)


def decode_path(
    positions: np.ndarray,
    unary: np.ndarray,
    *,
    times: np.ndarray,
    speed: float,
    accel: float,
) -> np.ndarray:
    """(T,) state per frame minimising Σ unary + velocity + acceleration costs (module doc).

    positions: (T, S, J, 3) the joints each of S states puts where (NaN: no evidence, costs
    nothing); unary: (T, S) each state's own cost; times: (T,) seconds; speed (m/s), accel (m/s²):
    the typical joint speed and acceleration the costs are measured in.
    """
    n_frames, n_states = unary.shape
    if n_frames == 0:
        return np.zeros(0, dtype=int)
    if n_frames == 1:
        return np.array([int(np.argmin(unary[0]))])
    dt = np.diff(times)
    unary = np.nan_to_num(unary, nan=0.0)
    step = positions[1:, None, :] - positions[:-1, :, None]  # (T-1, from, to, J, 3)
    vel = np.nan_to_num(np.sum(step**2, axis=(-1, -2))) / (speed * dt[:, None, None]) ** 2
    sigma_acc = accel * ((dt[:-1] + dt[1:]) / 2) ** 2
    cost = unary[0][:, None] + unary[1][None, :] + vel[0]  # (b, c) at frames 0, 1
    back = np.zeros((n_frames, n_states, n_states), dtype=np.int32)
    for t in range(2, n_frames):
        # states a, b, c at frames t-2, t-1, t (computed per frame: S³ memory, not T·S³)
        second = (
            positions[t][None, None]
            - 2 * positions[t - 1][None, :, None]
            + positions[t - 2][:, None, None]
        )
        acc = np.nan_to_num(np.sum(second**2, axis=(-1, -2))) / sigma_acc[t - 2] ** 2
        total = cost[:, :, None] + acc  # (a, b, c)
        back[t] = np.argmin(total, axis=0)
        cost = np.min(total, axis=0) + vel[t - 1] + unary[t][None, :]
    path = np.zeros(n_frames, dtype=int)
    path[-2], path[-1] = np.unravel_index(int(np.argmin(cost)), cost.shape)
    for t in range(n_frames - 1, 1, -1):
        path[t - 2] = back[t, path[t - 1], path[t]]
    return path


def torso_scale(
    lengths_px: dict[str, np.ndarray], ok: np.ndarray, *, window: int, percentile: float
) -> np.ndarray:
    """(T,) pixels per unit length at the neck's depth, up to one factor for the take, from the
    2D lengths (T,) of torso bones (`ok`: frames with a torso).

    A bone foreshortens, never lengthens, so each frame's scale is bounded by each bone's 2D
    length over its true one, and the least foreshortened bone (the largest ratio) comes nearest:
    the scale and the take's bone lengths (a high `percentile` of length / scale) are refined in
    turn from the spine's alone, the scale smoothed by a running median over `window` frames.
    """
    frames = np.arange(len(ok))

    def smooth(values: np.ndarray) -> np.ndarray:
        good = ok & np.isfinite(values) & (values > 0)
        filled = np.interp(frames, np.flatnonzero(good), values[good])
        return np.asarray(median_filter(filled, size=window, mode="nearest"))

    scale = smooth(lengths_px["spine"])
    for _ in range(3):
        true = {k: np.nanpercentile(v[ok] / scale[ok], percentile) for k, v in lengths_px.items()}
        scale = smooth(np.nanmax([v / true[k] for k, v in lengths_px.items()], axis=0))
    return scale
