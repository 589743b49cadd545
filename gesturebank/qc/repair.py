"""Repair of the main speaker's keypoints before they are judged (docs/architecture.md "Data flow").

Runs per take, at the video's own (possibly variable) timestamps, before clips are cut, so every
function copes with long NaN stretches (the person absent). Three repairs, in this order:

1. **Left/right swaps** (2D only): per body group (arms with the shoulders, legs with the hips,
   face), a two-state Viterbi — labels as given / exchanged — minimises the group's
   frame-to-frame path length plus a penalty per change of state (the face also pays for sides
   that disagree with the shoulders'); runs of at most `max_swap_s` that disagree with the
   labels before them are exchanged back. Swaps go first because exchanging rows back is
   lossless, while a Hampel filter run on an unrepaired swap takes the swapped samples for
   outliers (a 5-frame swap is 5 of the 13 samples of a 60 fps window) and replaces real,
   only mislabelled, positions by interpolation.
2. **Hampel outliers** in time, per keypoint: the distance to the window's coordinate-wise
   median point against 1.4826·MAD of the window's distances (MAD floored in shoulder widths).
   An outlier is set missing and then interpolated from its neighbours like a gap: linear
   interpolation keeps the local motion of a moving keypoint, where the window median lags
   behind it (and is one-sided at the edges), and an outlier next to a long gap stays missing
   instead of being invented.
3. **Gaps** up to `max_gap_s` are interpolated linearly in time (`filters.fill_gaps`); longer
   ones stay NaN. A filled sample gets the lower confidence of the two samples it is drawn
   between (the one, at an edge): it is no surer than its weaker anchor.

Distances are in shoulder widths (median over the take, in each array's own units), so pixels
and metres, near and far people share the thresholds. Hampel windows are given in seconds and
the swap cost is a path length, so the same motion gets the same repairs at 30 or 60 fps.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from gesturebank.config import RepairConfig
from gesturebank.filters import fill_gaps
from gesturebank.poses import Pose2D, Pose3D
from gesturebank.skeletons import COCO17, Skeleton, get_skeleton

F64 = NDArray[np.float64]
Bools = NDArray[np.bool_]

# 1 / Φ⁻¹(3/4): makes the MAD of Gaussian data an estimate of its standard deviation.
_MAD_TO_SIGMA = 1.4826
# The MAD is also floored at this many times the window's median frame-to-frame step: at the
# apex of a fast reversal the window median lags half the window's path behind, while the
# distances to it bunch up (MAD = one step at 50 fps), which would read as an outlier.
_STEP_FLOOR = 1.5
# Cost of one change between "as given" and "exchanged", shoulder widths of path length: far
# below what a real swap costs (each exchanged pair jumps twice the distance between its sides,
# and the arms carry the shoulders, ~1 width apart), far above what noise does.
_SWITCH_PENALTY = 0.5
# Body groups whose left/right labels flip together, by words of the unsided joint names, in the
# order they are repaired. Names are matched against legs first: BlazePose's "foot_index" is a
# foot, not a finger.
_GROUPS = {
    "arms": ("shoulder", "elbow", "wrist", "pinky", "index", "thumb", "hand"),
    "legs": ("hip", "knee", "ankle", "heel", "foot", "toe"),
    "face": ("eye", "ear", "mouth"),
}
_MATCH_ORDER = ("legs", "arms", "face")
# A group whose sides also have to agree with an anchor pair in every frame. The face's sides
# are a few pixels apart in 2D, too close for its motion alone to tell a swap; a head cannot
# turn its left ear to the right shoulder, so the (already repaired) shoulders say which is which.
_ANCHORS = {"face": ("left_shoulder", "right_shoulder")}


@dataclass(frozen=True, eq=False)
class RepairReport:
    """What the repair of one take changed.

    outliers:       keypoint samples the Hampel filter flagged (in 2D or world) and replaced by
                    interpolation (left NaN if they sit in a gap longer than max_gap_s).
    filled:         keypoint samples missing in the input and filled by interpolation (gaps
                    only; the refilled outliers are not counted again).
    swapped_frames: frames in which some body group's left/right labels were exchanged back
                    (frames inside such a run where the group was unseen count too).
    swap_runs:      runs of consecutive such frames.
    repaired:       (T, K) bool, keypoints whose position or confidence any repair changed.
    """

    outliers: int
    filled: int
    swapped_frames: int
    swap_runs: int
    repaired: Bools

    def counts(self) -> dict[str, int]:
        """The counts, for the manifest's `repairs` column."""
        return {
            "outliers": self.outliers,
            "filled": self.filled,
            "swapped_frames": self.swapped_frames,
            "swap_runs": self.swap_runs,
        }


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
# Left/right swaps


def _unsided(name: str) -> tuple[str, str] | None:
    """(side, name without it) of a sided joint name ("left_elbow", "mouth_left"), else None."""
    for side in ("left", "right"):
        if name.startswith(f"{side}_"):
            return side, name[len(side) + 1 :]
        if name.endswith(f"_{side}"):
            return side, name[: -len(side) - 1]
    return None


def swap_groups(skeleton: Skeleton) -> dict[str, NDArray[np.int64]]:
    """Left/right index pairs `(P, 2)` of each body group of `skeleton` that has a pair, derived
    from its left_/right_ joint names, in the order they are repaired: arms (with the
    shoulders), legs (with the hips), face.

    Each group is repaired alone, because one can swap without the others (legs of a stride);
    when BlazePose exchanges all labels at once (a person taken for facing the other way) each
    group sees its own swap. The face goes last: it is judged against the repaired shoulders."""
    sides: dict[str, dict[str, int]] = {}
    for i, name in enumerate(skeleton.joints):
        found = _unsided(name)
        if found is not None:
            sides.setdefault(found[1], {})[found[0]] = i
    groups: dict[str, list[tuple[int, int]]] = {}
    for base, pair in sides.items():
        if len(pair) != 2:
            continue
        group = next((g for g in _MATCH_ORDER if any(w in base for w in _GROUPS[g])), None)
        if group is not None:
            groups.setdefault(group, []).append((pair["left"], pair["right"]))
    return {g: np.array(sorted(groups[g]), dtype=np.int64) for g in _GROUPS if g in groups}


def _segments(seen: Bools, timestamps: F64, reset_gap_s: float) -> list[NDArray[np.int64]]:
    """Frame indices of the runs of `seen (T,)` frames with no absence longer than
    `reset_gap_s` between consecutive ones."""
    idx = np.flatnonzero(seen)
    if len(idx) == 0:
        return []
    breaks = np.flatnonzero(np.diff(timestamps[idx]) > reset_gap_s) + 1
    return np.split(idx, breaks)


def _ffill(values: F64) -> F64:
    """`values (n, ...)` with each NaN replaced by the last finite value before it (NaN before
    the first)."""
    ok = np.isfinite(values).all(axis=-1)
    t = np.arange(len(values)).reshape(-1, *([1] * (ok.ndim - 1)))
    last = np.maximum.accumulate(np.where(ok, t, 0), axis=0)
    out = np.take_along_axis(values, last[..., None], axis=0)
    seen = np.maximum.accumulate(ok, axis=0)
    return np.where(seen[..., None], out, np.nan)


def _step_costs(roles: F64, scale: float) -> tuple[F64, F64]:
    """Path length from each frame to the next of `roles (n, P, 2, C)` (left, right of each
    pair) in shoulder widths, keeping the labels (`same`) or exchanging them (`cross`): (n − 1,)
    each. A point's step counts where it is seen now and was seen before."""
    prev = _ffill(roles)[:-1]
    cur = roles[1:]
    same = np.linalg.norm(cur - prev, axis=-1)
    cross = np.linalg.norm(cur[:, :, ::-1] - prev, axis=-1)
    return np.nansum(same, axis=(1, 2)) / scale, np.nansum(cross, axis=(1, 2)) / scale


def _anchor_costs(roles: F64, anchor: F64, scale: float) -> F64:
    """(n,) how much farther the sides of `roles (n, P, 2, C)` are from the anchor pair
    `anchor (n, 2, C)` (left, right) when exchanged than as given, in shoulder widths."""
    given = np.nansum(np.linalg.norm(roles - anchor[:, None], axis=-1), axis=(1, 2))
    exchanged = np.nansum(np.linalg.norm(roles[:, :, ::-1] - anchor[:, None], axis=-1), axis=(1, 2))
    return (exchanged - given) / scale


def _viterbi(same: F64, cross: F64, penalty: float, exchanged: F64) -> Bools:
    """Cheapest state path `(n,)` (False = as given, True = exchanged) over n frames whose
    steps cost `same` when the state stays and `cross` + `penalty` when it changes, and whose
    frames cost `exchanged (n,)` more in the exchanged state; the labels before the first frame
    count as given."""
    n = len(same) + 1
    back = np.zeros((n, 2), dtype=bool)  # back[i, s]: the state before frame i was not s
    extra = exchanged.tolist()
    acc = [0.0, penalty + extra[0]]
    for i, (s, c) in enumerate(zip(same.tolist(), cross.tolist(), strict=True), start=1):
        stay0, move0 = acc[0] + s, acc[1] + c + penalty
        stay1, move1 = acc[1] + s, acc[0] + c + penalty
        back[i] = (move0 < stay0, move1 < stay1)
        acc = [min(stay0, move0), min(stay1, move1) + extra[i]]
    states = np.zeros(n, dtype=bool)
    states[-1] = acc[1] < acc[0]
    for i in range(n - 1, 0, -1):
        states[i - 1] = states[i] ^ back[i, int(states[i])]
    return states


def _runs(values: Bools) -> list[tuple[int, int]]:
    """[start, stop) of each run of equal values in `values (n,)`."""
    edges = np.flatnonzero(np.diff(values.astype(np.int8))) + 1
    bounds = np.concatenate([[0], edges, [len(values)]])
    return list(zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True))


def _short_runs(states: Bools, start_s: F64, end_s: F64, max_swap_s: float) -> Bools:
    """`(n,)` True on the frames of each run of `states` to exchange back: a run bounded on
    both sides, lasting at most `max_swap_s` (from its first frame's `start_s` to its last
    frame's `end_s`), whose state differs from that of its context: the last run before it
    that is not such (there is one: the first run is never flipped).

    The states are relative to the labels as given, so a short run of "as given" frames inside
    a long run of "exchanged" ones is as much a swap as the reverse. A run touching either end
    is never flipped and counts as context: it may go on beyond what was seen, and it needs one
    change of state instead of two, so the Viterbi enters it on weaker evidence. The context
    comes from before: a swap departs from the labels it follows, and a neighbouring swap
    (short too) does not change which labels those are.
    """
    flip = np.zeros(len(states), dtype=bool)
    context = False  # the state of the last run that is not a short one
    for a, b in _runs(states):
        short = 0 < a and b < len(states) and end_s[b - 1] - start_s[a] <= max_swap_s
        if short:
            flip[a:b] = bool(states[a]) != context
        else:
            context = bool(states[a])
    return flip


def swap_frames(
    *,
    points: np.ndarray,
    visible: np.ndarray,
    pairs: np.ndarray,
    timestamps: np.ndarray,
    scale: float,
    max_swap_s: float,
    reset_gap_s: float,
    anchor: np.ndarray | None = None,
) -> Bools:
    """(T,) True on the frames whose labels of one body group should be exchanged back.

    points (T, K, C), visible (T, K) bool (only visible points are evidence), pairs (P, 2)
    left/right indices of the group, scale: shoulder width in the points' units; anchor:
    optional (2,) indices of a pair whose sides the group's sides must also stay near (in the
    points' current labels). The group's frames with a visible point are cut where it was
    unseen for longer than `reset_gap_s`; in each piece `_viterbi` labels every frame as given
    or exchanged, and `_short_runs` picks the runs to flip back. The frames between a flipped
    run's first and last frame are flipped too (unseen ones change nothing).
    """
    ts = np.asarray(timestamps, dtype=np.float64)
    dt = float(np.median(np.diff(ts))) if len(ts) > 1 else 0.0
    end_s = np.append(ts[1:], ts[-1] + dt)  # when each frame ends
    roles = np.where(visible[..., None], points, np.nan)[:, pairs]  # (T, P, 2, C)
    seen = np.asarray(np.any(np.isfinite(roles).all(axis=-1), axis=(1, 2)))
    if anchor is None:
        prefer = np.zeros(len(ts))
    else:
        sides = np.where(visible[:, anchor, None], points[:, anchor], np.nan)  # (T, 2, C)
        prefer = _anchor_costs(roles, sides, scale)
    flip = np.zeros(len(ts), dtype=bool)
    for frames in _segments(seen, ts, reset_gap_s):
        if len(frames) < 2:
            continue
        same, cross = _step_costs(roles[frames], scale)
        states = _viterbi(same, cross, _SWITCH_PENALTY, prefer[frames])
        back = _short_runs(states, ts[frames], end_s[frames], max_swap_s)
        for a, b in _runs(back):
            if back[a]:
                flip[frames[a] : frames[b - 1] + 1] = True
    return flip


def exchange(values: np.ndarray, *, pairs: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """Copy of `values (T, K, ...)` with the left and right rows of `pairs (P, 2)` exchanged on
    the `frames (T,)` bool mask."""
    out = np.array(values, copy=True)
    rows = np.flatnonzero(frames)[:, None]
    left, right = values[rows, pairs[:, 0]], values[rows, pairs[:, 1]]
    out[rows, pairs[:, 0]], out[rows, pairs[:, 1]] = right, left
    return out


# --------------------------------------------------------------------------------------------------
# Validity


def validity(pose: Pose2D, *, visible_confidence: float) -> Bools:
    """(T, K) bool: the keypoint has a position and confidence >= `visible_confidence`."""
    with np.errstate(invalid="ignore"):
        return np.isfinite(pose.xy).all(axis=-1) & (pose.confidence >= visible_confidence)


# --------------------------------------------------------------------------------------------------
# Entry points


def _runs_of(mask: Bools) -> int:
    return int(np.sum(np.diff(np.concatenate([[0], mask.astype(np.int8)])) == 1))


def _changed(before: np.ndarray, after: np.ndarray) -> Bools:
    """(T, K) True where any channel of `(T, K, C)` differs (NaN equal to NaN)."""
    same = (before == after) | (np.isnan(before) & np.isnan(after))
    return ~same.all(axis=-1)


def _repair_swaps(
    kp: F64, world: F64 | None, timestamps: F64, skeleton: Skeleton, config: RepairConfig
) -> tuple[F64, F64 | None, Bools]:
    """Swap repair of 2D keypoints `(T, K, 3)` (and world `(T, K, 3)` alike, flipped where the
    2D labels are); returns them with the `(T,)` mask of frames where some group was flipped."""
    scale = shoulder_width(points=kp[..., :2], skeleton=skeleton)
    any_flip = np.zeros(len(kp), dtype=bool)
    if not np.isfinite(scale) or len(kp) < 2:
        return kp, world, any_flip
    with np.errstate(invalid="ignore"):
        visible = ~(kp[..., 2] < config.visible_confidence)  # NaN confidence counts as seen
    for group, pairs in swap_groups(skeleton).items():
        anchor = [skeleton.index[a] for a in _ANCHORS.get(group, ()) if a in skeleton.index]
        flip = swap_frames(
            points=kp[..., :2],
            visible=visible,
            pairs=pairs,
            timestamps=timestamps,
            scale=scale,
            max_swap_s=config.max_swap_s,
            # unseen for longer than any run repaired: labels across that are not compared
            reset_gap_s=config.max_swap_s,
            anchor=np.array(anchor) if len(anchor) == 2 else None,
        )
        if flip.any():
            kp = exchange(kp, pairs=pairs, frames=flip)
            world = None if world is None else exchange(world, pairs=pairs, frames=flip)
            visible = exchange(visible, pairs=pairs, frames=flip)
            any_flip |= flip
    return kp, world, any_flip


def _outliers(points: F64, timestamps: F64, skeleton: Skeleton, config: RepairConfig) -> Bools:
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


def _replace(points: F64, outliers: Bools, timestamps: F64, max_gap_s: float) -> tuple[F64, Bools]:
    """`points (T, K, C)` with the outliers set missing and every gap up to max_gap_s filled;
    returns them and the (T, K) samples filled."""
    cleared = points.copy()
    cleared[outliers] = np.nan
    return fill_keypoint_gaps(points=cleared, timestamps=timestamps, max_gap_s=max_gap_s)


def _refill(
    points: F64, confidence: F64, outliers: Bools, timestamps: F64, max_gap_s: float
) -> tuple[F64, F64, Bools]:
    """`_replace` with the confidence `(T, K)` of what was filled (`filled_confidence`; NaN for
    an outlier left missing); returns points, confidence and the (T, K) gap samples filled (the
    refilled outliers not among them)."""
    known = np.isfinite(points).all(axis=-1) & ~outliers
    out, filled = _replace(points, outliers, timestamps, max_gap_s)
    conf = filled_confidence(confidence=confidence, known=known, filled=filled)
    conf[outliers & ~filled] = np.nan
    return out, conf, filled & ~outliers


def repair_pose2d(pose: Pose2D, *, config: RepairConfig) -> tuple[Pose2D, RepairReport]:
    """Repaired copy of a take's main speaker `pose` and what was done (see the module doc).

    `pose.world`, when present, is repaired with the 2D keypoints: the same swap flips, and a
    keypoint that is an outlier in 2D or in world is replaced in both.
    """
    skeleton = get_skeleton(pose.skeleton)
    ts = pose.timestamps
    kp = pose.keypoints.astype(np.float64)
    world = None if pose.world is None else pose.world.astype(np.float64)
    flipped = np.zeros(len(kp), dtype=bool)
    if config.swaps:
        kp, world, flipped = _repair_swaps(kp, world, ts, skeleton, config)

    outliers = _outliers(kp[..., :2], ts, skeleton, config)
    if world is not None:
        outliers |= _outliers(world, ts, skeleton, config)
    xy, conf, gaps = _refill(kp[..., :2], kp[..., 2], outliers, ts, config.max_gap_s)
    out_kp = np.concatenate([xy, conf[..., None]], axis=-1)
    if world is not None:
        world, world_filled = _replace(world, outliers, ts, config.max_gap_s)
        gaps |= world_filled & ~outliers

    repaired = _changed(pose.keypoints.astype(np.float64), out_kp)
    if world is not None and pose.world is not None:
        repaired |= _changed(pose.world.astype(np.float64), world)
    report = RepairReport(
        outliers=int(outliers.sum()),
        filled=int(gaps.sum()),
        swapped_frames=int(flipped.sum()),
        swap_runs=_runs_of(flipped),
        repaired=repaired,
    )
    out = replace(
        pose,
        keypoints=out_kp.astype(np.float32),
        world=None if world is None else world.astype(np.float32),
    )
    return out, report


def repair_pose3d(pose: Pose3D, *, config: RepairConfig) -> tuple[Pose3D, RepairReport]:
    """Hampel outliers and short gaps of `pose.joints (T, 17, 3)`; no swap repair (lifters keep
    the labels they were given). Confidence of filled joints as in 2D."""
    ts = pose.timestamps
    joints = pose.joints.astype(np.float64)
    outliers = _outliers(joints, ts, COCO17, config)
    conf0 = pose.confidence.astype(np.float64)
    out_joints, conf, gaps = _refill(joints, conf0, outliers, ts, config.max_gap_s)
    before = np.concatenate([joints, conf0[..., None]], axis=-1)
    after = np.concatenate([out_joints, conf[..., None]], axis=-1)
    report = RepairReport(
        outliers=int(outliers.sum()),
        filled=int(gaps.sum()),
        swapped_frames=0,
        swap_runs=0,
        repaired=_changed(before, after),
    )
    out = replace(pose, joints=out_joints.astype(np.float32), confidence=conf.astype(np.float32))
    return out, report
