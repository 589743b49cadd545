"""Who is who across frames: identities of the people a detector saw, and shot boundaries.

Identities come from the detector when it tracks people itself (`MultiPose2D.ids`), else from
`link` (Hungarian matching of detections to live tracks on keypoint distance, gated).
`split_at_cuts` renumbers them so that no identity spans a shot cut: across a cut the camera,
and often the person, changes, and a track carried over would mix two people. `find_switches`
reports hand-overs between tracks (a single-person detector jumping from one person to another).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from gesturebank.config import TrackingConfig
from gesturebank.poses import MultiPose2D, Pose2D

_FAR = 1e12  # cost of a gated-out pair
_CUT_EPS_S = 1e-6  # a frame this close before a cut time already belongs to the new shot


@dataclass(frozen=True)
class Switch:
    """Track `old_id` was last seen shortly before `new_id` first appeared at `timestamp`."""

    timestamp: float
    old_id: int
    new_id: int


def pose_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Confidence-weighted mean pixel distance of two poses `(K, 3)`; inf if no joint in common."""
    d = np.linalg.norm(a[:, :2] - b[:, :2], axis=-1)
    w = np.clip(np.minimum(a[:, 2], b[:, 2]), 0.05, 1.0)
    ok = np.isfinite(d) & np.isfinite(w)
    if not ok.any():
        return float("inf")
    return float(np.sum(d[ok] * w[ok]) / np.sum(w[ok]))


def _centroid(kp: np.ndarray) -> np.ndarray:
    return np.nanmean(kp[:, :2], axis=0)


def link(multi: MultiPose2D, *, config: TrackingConfig) -> np.ndarray:
    """Track id of every slot, `(T, P)` int64, -1 where the slot is empty.

    config (the `tracking` section): `gate` is the largest match distance as a fraction of the
    image diagonal for consecutive frames; a track lost for `lost` seconds accepts
    `gate × (1 + lost / 1 s)` (people move while unseen).
    Tracks unseen for more than `max_lost_s` end. Over gaps up to `predict_s` the last pose is
    shifted by the track's centroid velocity (helps people crossing each other).
    """
    gate, max_lost_s, predict_s = config.gate, config.max_lost_s, config.predict_s
    w, h = multi.image_size
    gate_px = gate * float(np.hypot(w, h))
    present = multi.present
    ids = np.full(present.shape, -1, np.int64)
    # Per live track: last pose (K, 3), last time, centroid velocity (px/s).
    last: dict[int, np.ndarray] = {}
    seen: dict[int, float] = {}
    vel: dict[int, np.ndarray] = {}
    next_id = 0
    for t, now in enumerate(multi.timestamps):
        for tid in [k for k, s in seen.items() if now - s > max_lost_s]:
            del last[tid], seen[tid], vel[tid]
        slots = np.flatnonzero(present[t])
        tracks = list(last)
        cost = np.full((len(tracks), len(slots)), _FAR)
        for i, tid in enumerate(tracks):
            lost = now - seen[tid]
            ref = last[tid].copy()
            if lost <= predict_s:
                ref[:, :2] += vel[tid] * lost
            limit = gate_px * (1.0 + lost)
            for j, p in enumerate(slots):
                d = pose_distance(ref, multi.keypoints[t, p])
                if d <= limit:
                    cost[i, j] = d
        rows, cols = linear_sum_assignment(cost) if cost.size else ([], [])
        matched = set()
        for i, j in zip(rows, cols, strict=True):
            if cost[i, j] >= _FAR:
                continue
            tid, p = tracks[i], slots[j]
            kp = multi.keypoints[t, p]
            dt = now - seen[tid]
            vel[tid] = (_centroid(kp) - _centroid(last[tid])) / dt if dt > 0 else vel[tid]
            last[tid], seen[tid] = kp, now
            ids[t, p] = tid
            matched.add(j)
        for j, p in enumerate(slots):
            if j not in matched:
                ids[t, p] = next_id
                last[next_id] = multi.keypoints[t, p]
                seen[next_id] = now
                vel[next_id] = np.zeros(2)
                next_id += 1
    return ids


def shot_index(*, timestamps: np.ndarray, cuts: np.ndarray | None) -> np.ndarray:
    """(T,) int64 shot of every frame: the number of cuts at or before its timestamp.

    cuts: (S,) seconds, the first frame of each new shot (None or empty: one shot).
    """
    ts = np.asarray(timestamps, dtype=np.float64)
    if cuts is None or len(cuts) == 0:
        return np.zeros(len(ts), np.int64)
    edges = np.sort(np.asarray(cuts, dtype=np.float64)) - _CUT_EPS_S
    return np.searchsorted(edges, ts, side="right").astype(np.int64)


def split_at_cuts(*, ids: np.ndarray, shot: np.ndarray) -> np.ndarray:
    """(T, P) ids renumbered so that each (shot, id) pair is its own identity.

    ids: (T, P) int64, -1 = empty; shot: (T,) from `shot_index`. New ids count from 0 in order
    of first appearance (frame, then slot), so the result does not depend on the input's ids.
    """
    out = np.full(ids.shape, -1, np.int64)
    t_idx, p_idx = np.nonzero(ids >= 0)  # row-major: in order of appearance
    if len(t_idx) == 0:
        return out
    pairs = np.stack([shot[t_idx], ids[t_idx, p_idx]], axis=1)
    _, first, inverse = np.unique(pairs, axis=0, return_index=True, return_inverse=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    out[t_idx, p_idx] = rank[inverse.reshape(-1)]
    return out


def find_switches(
    timestamps: np.ndarray, ids: np.ndarray, *, window_s: float = TrackingConfig().switch_window_s
) -> tuple[Switch, ...]:
    """Hand-overs: a track (re)appears within `window_s` after another one vanished.

    ids: (T, P) from `link`. A single-person detector jumping from one person to another shows
    up exactly like this; a person merely leaving, or appearing next to others, does not. Each
    disappearance pairs with at most one appearance (the nearest in time). Run it per shot: at a
    cut every track ends and new ones begin.
    """
    ts = np.asarray(timestamps, dtype=np.float64)
    present = {int(k): (ids == k).any(axis=1) for k in np.unique(ids[ids >= 0])}
    appear = sorted(
        (int(b) + 1, k) for k, p in present.items() for b in np.flatnonzero(~p[:-1] & p[1:])
    )
    vanish = [(int(a), k) for k, p in present.items() for a in np.flatnonzero(p[:-1] & ~p[1:])]
    out: list[Switch] = []
    used: set[tuple[int, int]] = set()
    for b, new in appear:
        gone = [
            (a, old)
            for a, old in vanish
            if old != new
            and (a, old) not in used
            and a < b
            and not present[old][a + 1 : b + 1].any()
            and ts[b] - ts[a] <= window_s
        ]
        if gone:
            a, old = max(gone)
            used.add((a, old))
            out.append(Switch(float(ts[b]), old, new))
    return tuple(out)


def gather(multi: MultiPose2D, ids: np.ndarray, *, track_id: int | np.ndarray) -> Pose2D:
    """The Pose2D of one track, or of a `(T,)` track id per frame (-1 = nobody): (T, K, 3), NaN
    in frames where that track is absent."""
    want = np.broadcast_to(np.asarray(track_id, dtype=np.int64), (len(multi),))
    t_idx, p_idx = np.nonzero((ids == want[:, None]) & (want[:, None] >= 0))
    kp = np.full(multi.keypoints.shape[:1] + multi.keypoints.shape[2:], np.nan, np.float32)
    kp[t_idx] = multi.keypoints[t_idx, p_idx]
    world = None
    if multi.world is not None:
        world = np.full_like(kp, np.nan)
        world[t_idx] = multi.world[t_idx, p_idx]
    return Pose2D(kp, multi.timestamps, multi.skeleton, multi.image_size, world)


# ------------------------------------------------------------------------- motion and speech
