"""The left/right swap repair (2D only; the first of `gesturebank.repair`'s three): per body
group, a two-state Viterbi — labels as given / exchanged — over the group's frame-to-frame path
length, and the short runs that disagree with the labels before them exchanged back; a second
path that also weighs the take's usual facing (`_FACING_PAIRS`) replaces it where every run it
adds looks like a skeleton the detector turned round (`_facing_explains`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gesturebank.config import RepairConfig
from gesturebank.repair.keypoints import F64, Bools, shoulder_width
from gesturebank.skeletons import Skeleton

# Cost of one change between "as given" and "exchanged", shoulder widths of path length: far
# below what a real swap costs (each exchanged pair jumps twice the distance between its sides,
# and the arms carry the shoulders, ~1 width apart), far above what noise does.
_SWITCH_PENALTY = 0.5
# A point last seen longer ago than this is no evidence of where its label went, seconds (3
# frames at 30 fps: a joint BlazePose loses for longer has moved on).
_FRESH_S = 0.1
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
# The pair of a group whose sides say which way the torso faces in 2D: the take's usual facing
# is a weak preference (issue 41). A detector that takes a person for turned round exchanges
# every label, and may enter that gradually (its skeleton turns over a few frames: no exchange
# step to see) and leave it in one step, or the reverse. The motion then tells only that the
# labels before and after the step differ, not which are right, and the run touching the take's
# end was taken for right (test3.bvh at 0°: 0.97 s facing away, put right in one step at its
# end, so the 10 s after it were called exchanged and nothing was repaired). Shoulder widths
# per second facing the unusual way: a run of up to 2 s gains no more from it than its two
# switches cost, so the preference alone never flips a short run; it decides between label
# paths the motion explains about as well. But a person really turns round too (the detector
# following), and fast motion makes jumps that look like exchange steps: the path with the
# preference is taken only where every run it adds faces the unusual way as given and meets
# the usual way on both sides (issue 39: a held-out fast render, its real turns and a jump
# flipped, 5.9 % of frames exchanged against 0 without the preference).
_FACING_PAIRS = {"arms": "shoulder", "legs": "hip"}
_FACING_PER_S = _SWITCH_PENALTY


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


def _ffill(values: F64, times: F64, max_age_s: float) -> F64:
    """`values (n, ..., C)` with each NaN replaced by the last finite value before it, when that
    was taken at most `max_age_s` before (`times (n,)` s); NaN otherwise, and before the first."""
    ok = np.isfinite(values).all(axis=-1)
    t = np.arange(len(values)).reshape(-1, *([1] * (ok.ndim - 1)))
    last = np.maximum.accumulate(np.where(ok, t, -1), axis=0)
    out = np.take_along_axis(values, np.maximum(last, 0)[..., None], axis=0)
    age = times.reshape(t.shape) - times[np.maximum(last, 0)]
    fresh = (last >= 0) & (age <= max_age_s + 1e-9)
    return np.where(fresh[..., None], out, np.nan)


def _step_costs(roles: F64, times: F64, scale: float) -> tuple[F64, F64]:
    """Path length from each frame to the next of `roles (n, P, 2, C)` (left, right of each
    pair) at `times (n,)` s in shoulder widths, keeping the labels (`same`) or exchanging them
    (`cross`): (n − 1,) each. A pair counts in a step only where both its sides are seen now and
    were seen at most `_FRESH_S` before.

    One side alone is no evidence: exchanged, the seen point is compared with where the other
    side was last seen, which for a hidden arm (the far one at 45°, or one behind the back) is
    a stale guess. On fast motion such one-sided steps made the repair exchange right labels
    (issue 39: a render of test2.bvh's most vigorous 20 s, BlazePose on each frame, 2.2 % of
    frames exchanged before the repair and 11.8 % after)."""
    prev = _ffill(roles, times, _FRESH_S)[:-1]
    cur = roles[1:]
    both = np.isfinite(cur).all(axis=(-2, -1)) & np.isfinite(prev).all(axis=(-2, -1))  # (n, P)
    cur = np.where(np.asarray(both)[..., None, None], cur, np.nan)
    same = np.linalg.norm(cur - prev, axis=-1)
    cross = np.linalg.norm(cur[:, :, ::-1] - prev, axis=-1)
    return np.nansum(same, axis=(1, 2)) / scale, np.nansum(cross, axis=(1, 2)) / scale


def _anchor_costs(roles: F64, anchor: F64, scale: float) -> F64:
    """(n,) how much farther the sides of `roles (n, P, 2, C)` are from the anchor pair
    `anchor (n, 2, C)` (left, right) when exchanged than as given, in shoulder widths."""
    given = np.nansum(np.linalg.norm(roles - anchor[:, None], axis=-1), axis=(1, 2))
    exchanged = np.nansum(np.linalg.norm(roles[:, :, ::-1] - anchor[:, None], axis=-1), axis=(1, 2))
    return (exchanged - given) / scale


def _facing_costs(
    points: F64, visible: Bools, *, skeleton: Skeleton, pair: str, timestamps: F64
) -> F64:
    """(T,) how much more the exchanged labels of `pair` ("shoulder", "hip") cost in each frame
    of `points (T, K, 2)`: +_FACING_PER_S × the frame's length where the labels as given face
    the take's usual way, minus that where they face the other way, 0 where the torso is not
    seen. Facing as `qc.views` tells it: right → left across the torso's up (mid-hips →
    mid-shoulders, or mid-shoulders → nose) turned clockwise faces away (image y down)."""
    idx = skeleton.index
    need = ("left_shoulder", "right_shoulder", "left_hip", "right_hip", "nose")
    if not all(n in idx for n in need) or f"left_{pair}" not in idx:
        return np.zeros(len(points))
    xy = np.where(visible[..., None], points[..., :2], np.nan)
    shoulders = (xy[:, idx["left_shoulder"]] + xy[:, idx["right_shoulder"]]) / 2
    hips = (xy[:, idx["left_hip"]] + xy[:, idx["right_hip"]]) / 2
    up = shoulders - hips
    up = np.where(np.isfinite(up), up, xy[:, idx["nose"]] - shoulders)
    across = xy[:, idx[f"left_{pair}"]] - xy[:, idx[f"right_{pair}"]]
    turn = across[:, 0] * up[:, 1] - across[:, 1] * up[:, 0]
    seen = np.isfinite(turn) & (turn != 0)
    if not seen.any():
        return np.zeros(len(points))
    usual = np.mean(turn[seen] > 0) > 0.5  # the take faces away more often than not
    ts = np.asarray(timestamps, np.float64)
    dt = np.diff(ts, append=ts[-1] + (np.median(np.diff(ts)) if len(ts) > 1 else 0.0))
    sign = np.where((turn > 0) == usual, 1.0, -1.0)
    return np.where(seen, sign * _FACING_PER_S * dt, 0.0)


def _facing_explains(runs: Bools, facing: F64) -> bool:
    """Whether every run of `runs (n,)` looks like a skeleton the detector turned round: as
    given, its labels face the unusual way (`facing (n,)` < 0, `_facing_costs`) in most of
    the frames of each of its halves where the facing is told (≠ 0), and the usual way (> 0)
    in the nearest told frame on either side of it. A run flipped only for the usual facing
    that faces the usual way over half of it, or where it meets its context, is no such
    skeleton: the detector followed a real turn there, or the run is the wrong side of a jump
    the fast motion made (issue 39)."""
    told = np.flatnonzero(facing != 0)
    for a, b in _runs(runs):
        if not runs[a]:
            continue
        inside = told[(told >= a) & (told < b)]
        outside = [told[told < a][-1:], told[told >= b][:1]]
        m = len(inside)  # an odd run's middle frame counts in both halves: time has no direction
        halves = [inside[: (m + 1) // 2], inside[m // 2 :]]
        if any(np.mean(facing[h] < 0) <= 0.5 for h in halves if len(h)) or not len(inside):
            return False
        if any(len(o) and facing[o[0]] < 0 for o in outside):
            return False
    return True


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
    facing: np.ndarray | None = None,
) -> Bools:
    """(T,) True on the frames whose labels of one body group should be exchanged back.

    points (T, K, C), visible (T, K) bool (only visible points are evidence), pairs (P, 2)
    left/right indices of the group, scale: shoulder width in the points' units; anchor:
    optional (2,) indices of a pair whose sides the group's sides must also stay near (in the
    points' current labels); facing: optional (T,) cost of the exchanged labels per frame
    (`_facing_costs`). The group's frames with a visible point are cut where it was
    unseen for longer than `reset_gap_s`; in each piece `_viterbi` labels every frame as given
    or exchanged, and `_short_runs` picks the runs to flip back. With `facing`, a second path
    that adds it to the costs is taken instead where `_facing_explains` every run it flips and
    the first does not. The frames between a flipped run's first and last frame are flipped
    too (unseen ones change nothing).
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
        same, cross = _step_costs(roles[frames], ts[frames], scale)
        states = _viterbi(same, cross, _SWITCH_PENALTY, prefer[frames])
        back = _short_runs(states, ts[frames], end_s[frames], max_swap_s)
        if facing is not None:
            turned = _viterbi(same, cross, _SWITCH_PENALTY, prefer[frames] + facing[frames])
            also = _short_runs(turned, ts[frames], end_s[frames], max_swap_s)
            if _facing_explains(also & ~back, facing[frames]):
                back = also
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
# The take's 2D (and world) keypoints


def repair_swaps(
    kp: F64, world: F64 | None, *, timestamps: F64, skeleton: Skeleton, config: RepairConfig
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
        facing = None
        if group in _FACING_PAIRS:
            facing = _facing_costs(
                kp, visible, skeleton=skeleton, pair=_FACING_PAIRS[group], timestamps=timestamps
            )
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
            facing=facing,
        )
        if flip.any():
            kp = exchange(kp, pairs=pairs, frames=flip)
            world = None if world is None else exchange(world, pairs=pairs, frames=flip)
            visible = exchange(visible, pairs=pairs, frames=flip)
            any_flip |= flip
    return kp, world, any_flip
