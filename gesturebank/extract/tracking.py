"""Identity across frames and the choice of the main speaker, for multi-person detections.

1. `link`: frame by frame, Hungarian assignment (scipy's linear_sum_assignment) of detections to
   live tracks on mean keypoint distance, with a gate (a fraction of the image diagonal, widened
   for a track that has been lost for a while). Unmatched detections start new tracks.
2. `track_scores`: per track, the sum over its frames of a weighted score — upper-body size,
   closeness to the image centre, keypoint confidence (TrackingConfig weights) — divided by T,
   so a person seen all along beats a passer-by.
3. `find_switches`: a track vanishing and another appearing shortly after is reported as an
   identity switch (the detector probably jumped from one person to another, or lost one).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from gesturebank.config import TrackingConfig
from gesturebank.errors import DetectionError
from gesturebank.extract.detectors import MultiPose2D
from gesturebank.poses import Pose2D
from gesturebank.skeletons import COCO17, get_skeleton

UPPER_BODY = tuple(j for j in COCO17.joints if "knee" not in j and "ankle" not in j)
_FAR = 1e12  # cost of a gated-out pair


@dataclass(frozen=True)
class Switch:
    """Track `old_id` was last seen shortly before `new_id` first appeared at `timestamp`."""

    timestamp: float
    old_id: int
    new_id: int


@dataclass(frozen=True)
class TrackReport:
    """Outcome of tracking one take.

    main_id: chosen track; scores: score per track id; main_coverage: fraction of frames where
    the main speaker is present; switches: every switch; main_switches: those involving main_id.
    """

    n_tracks: int
    main_id: int
    scores: dict[int, float]
    main_coverage: float
    switches: tuple[Switch, ...]

    @property
    def main_switches(self) -> tuple[Switch, ...]:
        return tuple(s for s in self.switches if self.main_id in (s.old_id, s.new_id))


@dataclass(frozen=True)
class Tracked:
    """The main speaker's Pose2D, the (T, P) track id of every slot (-1 = empty), the report."""

    pose: Pose2D
    ids: np.ndarray
    report: TrackReport


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


def link(
    multi: MultiPose2D,
    gate: float = TrackingConfig().gate,
    *,
    max_lost_s: float = 2.0,
    predict_s: float = 0.2,
) -> np.ndarray:
    """Track id of every slot, `(T, P)` int64, -1 where the slot is empty.

    gate: largest match distance as a fraction of the image diagonal for consecutive frames; a
    track lost for `lost` seconds accepts `gate × (1 + lost / 1 s)` (people move while unseen).
    Tracks unseen for more than `max_lost_s` end. Over gaps up to `predict_s` the last pose is
    shifted by the track's centroid velocity (helps people crossing each other).
    """
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


def _upper_body(multi: MultiPose2D) -> np.ndarray:
    """(T, P, U, 3) upper-body joints (COCO-17 names) of every slot; NaN where absent."""
    skel = get_skeleton(multi.skeleton)
    coco = skel.convert(multi.keypoints, COCO17)
    return coco[..., [COCO17.index[j] for j in UPPER_BODY], :]


def frame_scores(multi: MultiPose2D, config: TrackingConfig) -> np.ndarray:
    """(T, P) speaker score of every slot (NaN where empty): weighted size, centrality, confidence.

    size: upper-body bounding-box diagonal / the largest in the take; centrality: 1 − distance of
    the upper-body centroid to the image centre / half the diagonal; confidence: mean of the
    upper-body joints (missing joints count 0).
    """
    ub = _upper_body(multi)
    conf = np.nan_to_num(ub[..., 2], nan=0.0).mean(axis=-1)
    xy = ub[..., :2]
    has = np.isfinite(xy[..., 0]).any(axis=-1)
    with warnings.catch_warnings():  # empty slots: all-NaN slices are expected
        warnings.simplefilter("ignore", RuntimeWarning)
        lo, hi = np.nanmin(xy, axis=-2), np.nanmax(xy, axis=-2)
        centre = np.nanmean(xy, axis=-2)
    size = np.linalg.norm(hi - lo, axis=-1)
    size = size / max(float(np.nanmax(np.where(has, size, np.nan), initial=0.0)), 1e-9)
    w, h = multi.image_size
    half_diag = np.hypot(w, h) / 2
    central = 1.0 - np.linalg.norm(centre - np.array([w / 2, h / 2]), axis=-1) / half_diag
    score = (
        config.size_weight * size
        + config.center_weight * np.clip(central, 0.0, 1.0)
        + config.confidence_weight * conf
    )
    return np.where(has, score, np.nan)


def track_scores(multi: MultiPose2D, ids: np.ndarray, config: TrackingConfig) -> dict[int, float]:
    """Score of every track id: sum of its frame scores / T (presence counts)."""
    scores = frame_scores(multi, config)
    n = max(len(multi), 1)
    out: dict[int, float] = {}
    for tid in np.unique(ids[ids >= 0]):
        out[int(tid)] = float(np.nansum(np.where(ids == tid, scores, np.nan)) / n)
    return out


def find_switches(
    timestamps: np.ndarray, ids: np.ndarray, window_s: float = 0.5
) -> tuple[Switch, ...]:
    """Hand-overs: a track (re)appears within `window_s` after another one vanished.

    ids: (T, P) from `link`. A single-person detector jumping from one person to another shows
    up exactly like this; a person merely leaving, or appearing next to others, does not. Each
    disappearance pairs with at most one appearance (the nearest in time).
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


def gather(multi: MultiPose2D, ids: np.ndarray, track_id: int) -> Pose2D:
    """The Pose2D of one track: (T, K, 3), NaN in frames where the track is absent."""
    t_idx, p_idx = np.nonzero(ids == track_id)
    kp = np.full(multi.keypoints.shape[:1] + multi.keypoints.shape[2:], np.nan, np.float32)
    kp[t_idx] = multi.keypoints[t_idx, p_idx]
    world = None
    if multi.world is not None:
        world = np.full_like(kp, np.nan)
        world[t_idx] = multi.world[t_idx, p_idx]
    return Pose2D(kp, multi.timestamps, multi.skeleton, multi.image_size, world)


def main_speaker(
    multi: MultiPose2D, config: TrackingConfig | None = None, *, source: str = "take"
) -> Tracked:
    """Link identities, pick the best-scoring track, return its Pose2D and the report.

    Raises DetectionError (naming `source`) when nobody is found in any frame.
    """
    config = config or TrackingConfig()
    ids = link(multi, config.gate, max_lost_s=config.max_lost_s, predict_s=config.predict_s)
    scores = track_scores(multi, ids, config)
    if not scores:
        raise DetectionError(f"{source}: no person detected in any of {len(multi)} frames")
    main_id = max(scores, key=lambda k: scores[k])
    coverage = float((ids == main_id).any(axis=1).mean())
    report = TrackReport(
        n_tracks=len(scores),
        main_id=main_id,
        scores=scores,
        main_coverage=coverage,
        switches=find_switches(multi.timestamps, ids, config.switch_window_s),
    )
    return Tracked(gather(multi, ids, main_id), ids, report)
