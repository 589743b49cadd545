"""Joint trajectories that stay on their side: continuous angles, free angles held, and the
robot's reach (`[retarget] reach`).

- `continuous`: each angle on the branch nearest its previous frame (an atan2 that crosses ±π
  steps by 2π; unwrapped it does not), starting on its principal branch [−π, π], whose middle
  is the middle of the range of every Pepper joint whose atan2 can cross ±π (HeadYaw,
  ShoulderPitch, ElbowYaw): a trajectory that leaves the range stays beyond the limit it left
  from instead of reappearing beyond the other one.
- `unlimited_angles`: the person's raw angles made continuous, interpolated onto a clock and
  low-passed, not yet limited: what the dataset's angles are made from (`datasets.process`) and
  what the QC measures reach against.
- `hold_free`: a free (singular) angle blended towards its previous value with a weight that
  falls to 0 where it stops moving the robot (ElbowYaw at a straight elbow).
- `reach_map`: the person's angle → an angle the robot can take, once, where the dataset's
  angles are made. "clamp" holds a joint at its limit while the person is beyond it; "soft"
  compresses the last `soft_margin` rad before each limit with a tanh (value and slope continuous
  at the margin's edge, strictly increasing, never reaching the limit), so motion beyond reach
  still moves the robot, with the person's timing, and stays ordered as the person's angle.
"""

from __future__ import annotations

import math

import numpy as np

from gesturebank.config import ProcessingConfig, RetargetConfig
from gesturebank.filters import GapReport, butter_lowpass, interpolate_at
from gesturebank.robot import pepper

TURN = 2.0 * np.pi


def continuous(
    angles: np.ndarray, lower: np.ndarray | None = None, *, upper: np.ndarray | None = None
) -> np.ndarray:
    """`angles (T, D)` rad → float64 (T, D): each column unwrapped over its finite values, i.e.
    every known frame on the branch nearest the previous known one (across NaN gaps too), the
    first known frame on its principal branch [−π, π]: a trajectory is anchored where it starts
    and stays on the side it left the range from. With the joints' limits `lower`, `upper`
    (D,), an angle that comes back inside them on another branch (an arm that went on round
    behind the back and down), or comes clearly nearer the other limit (`SWITCH_MARGIN`), is
    taken there, and the trajectory goes on from it. NaN stays NaN;
    a column without a step across ±π comes back bit for bit."""
    out = np.array(angles, dtype=np.float64, copy=True)
    flat = out.reshape(len(out), -1)
    for j, col in enumerate(flat.T):
        known = np.isfinite(col)
        if not known.any():
            continue
        values = np.unwrap(col[known])
        turns = np.round(values[0] / TURN)
        if turns:
            values -= turns * TURN
        if lower is not None and upper is not None:
            values = _back_in_range(values, float(lower[j]), float(upper[j]))
        col[known] = values
    return out


# How much nearer the robot's range another branch of an angle beyond it must be before the
# trajectory is taken there (rad): an angle that goes on past ±π stays on its side until it is
# clearly nearer the other limit — for a joint with limits ±119.5°, beyond about ±209° (the
# 4-camera demo's triangulated forearm turned on to a median 218° = −142° froze the robot's
# ElbowYaw for 3 s) — and no noise around ±π itself can flip it.
SWITCH_MARGIN = 1.0


def _back_in_range(values: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """An unwrapped trajectory moved by whole turns from each frame where another branch of it
    lies inside the limits [lo, hi] while it lies beyond them, or lies more than
    `SWITCH_MARGIN` nearer them."""

    def beyond(v: np.ndarray | float) -> np.ndarray:
        return np.maximum(np.maximum(lo - np.asarray(v), np.asarray(v) - hi), 0.0)

    d = beyond(values)
    best = np.minimum(beyond(values - TURN), beyond(values + TURN))
    if not np.any((d > 0) & ((best == 0) | (best + SWITCH_MARGIN < d))):
        return values
    out = values.tolist()
    shift = 0.0
    for t, raw in enumerate(values.tolist()):
        value = raw + shift
        own = float(beyond(value))
        if own > 0:
            for turn in (-TURN, TURN):
                other = float(beyond(value + turn))
                if other == 0 or other + SWITCH_MARGIN < own:
                    shift, value, own = shift + turn, value + turn, other
        out[t] = value
    return np.asarray(out, dtype=np.float64)


def unlimited_angles(
    *,
    raw: np.ndarray,
    timestamps: np.ndarray,
    clock: np.ndarray,
    processing: ProcessingConfig,
    profile: pepper.RobotProfile,
) -> tuple[np.ndarray, GapReport]:
    """`raw (T, 11)` rad at `timestamps (T,)` → the person's angles on `clock (N,)`, low-passed
    and continuous, not yet limited: `(N, 11)` float64 and the gaps met. An angle beyond ±π
    (an arm overhead and behind, a head turned away) stays on the branch it reached, so it is
    never filtered as a sweep across the joint's range nor wrapped to the other side of it,
    until it comes back inside `profile`'s limits on another branch (`continuous`)."""
    p = processing
    steady = continuous(raw, profile.lower, upper=profile.upper)
    angles, gaps = interpolate_at(steady, timestamps, query=clock, max_gap_s=p.max_gap_s)
    smooth = butter_lowpass(angles, p.rate_hz, cutoff_hz=p.cutoff_hz, order=p.butter_order)
    return smooth, gaps


def hold_free(values: np.ndarray, weight: np.ndarray, *, start: float = 0.0) -> np.ndarray:
    """A free angle `values (T,)` rad resolved over time with `weight (T,)` in [0, 1] (1: the
    angle is measured well, 0: it moves nothing): v_t = h + w_t · wrap(x_t − h), where h is the
    last value with full weight (`start` before there was one). An angle that straightens and
    bends again in the same plane keeps its value; one whose plane turns while it is straight
    turns with the weight, i.e. with the bend, whatever the frame rate. NaN stays NaN."""
    x = np.asarray(values, dtype=np.float64)
    w = np.asarray(weight, dtype=np.float64)
    out = np.full(len(x), np.nan)
    ok = np.isfinite(x) & np.isfinite(w)
    if ok.all() and np.all(w >= 1.0):
        return x.copy()  # nothing is free: the measured angle throughout
    held, pi = float(start), math.pi
    result = out.tolist()
    for t, (xt, wt, known) in enumerate(zip(x.tolist(), w.tolist(), ok.tolist(), strict=True)):
        if known:  # Python floats: a per-frame loop over numpy scalars is 20× slower
            turn = (xt - held + pi) % TURN - pi
            # A plane that turned by about π while straight: turn the way that stays in
            # [−π, π], the middle of the joint's range, rather than out beyond a limit.
            if abs(turn) > pi / 2 and abs(held + turn) > pi:
                turn -= math.copysign(TURN, turn)
            result[t] = held + wt * turn
            if wt >= 1.0:
                held = result[t]
    return np.asarray(result, dtype=np.float64)


def soft_limits(
    angles: np.ndarray, lower: np.ndarray, *, upper: np.ndarray, margin: float
) -> np.ndarray:
    """`angles (N, D)` compressed into (lower, upper) per column: identity up to `margin` rad
    m (at most a quarter of the range) from a limit, edge + m·tanh((x − edge) / m) beyond that
    edge: continuous in value and slope, strictly increasing, inside the open range."""
    a = np.asarray(angles, dtype=np.float64)
    lo, hi = np.asarray(lower, np.float64), np.asarray(upper, np.float64)
    m = np.minimum(float(margin), (hi - lo) / 4.0)
    if not np.all(m > 0):
        return np.clip(a, lo, hi)
    top, bottom = hi - m, lo + m
    with np.errstate(invalid="ignore"):
        out = np.where(a > top, top + m * np.tanh((a - top) / m), a)
        return np.where(a < bottom, bottom + m * np.tanh((a - bottom) / m), out)


def reach_map(
    angles: np.ndarray, *, profile: pepper.RobotProfile, retarget: RetargetConfig
) -> np.ndarray:
    """The person's continuous angles `(N, 11)` → angles inside `profile`'s limits, float32, by
    `retarget.reach` ("clamp" or "soft" with `retarget.soft_margin`). Applied once, where the
    dataset's angles are made; players only guard the limits (`pepper.clamp`)."""
    a = np.asarray(angles, dtype=np.float64)
    if retarget.reach == "soft":
        a = soft_limits(a, profile.lower, upper=profile.upper, margin=retarget.soft_margin)
    # clamped in the stored dtype: float32(limit) can lie outside the float64 limit
    return pepper.clamp(a.astype(np.float32), profile)


def _rate_limited(x: np.ndarray, step: float) -> np.ndarray:
    """`x (N,)` followed with steps of at most `step` (starting on x[0])."""
    values = x.tolist()
    out = [values[0]]
    for v in values[1:]:
        out.append(out[-1] + min(step, max(-step, v - out[-1])))
    return np.asarray(out, dtype=np.float64)


def speed_limit(angles: np.ndarray, max_step: np.ndarray) -> np.ndarray:
    """`angles (N, D)` whose steps between samples stay within `max_step (D,)`: each finite run
    rate-limited forwards and backwards, and the two averaged, so the limit adds no lag and
    no direction of time is preferred; an average of two sequences inside the limits and within
    `max_step` is too. A run that never steps faster comes back unchanged."""
    a = np.asarray(angles, dtype=np.float64)
    out = a.copy()
    for j in range(a.shape[1]):
        col = a[:, j]
        known = np.isfinite(col)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], known.astype(np.int8), [0]])))
        for start, stop in zip(edges[::2], edges[1::2], strict=True):
            run = col[start:stop]
            if len(run) < 2 or np.abs(np.diff(run)).max() <= max_step[j]:
                continue
            fwd = _rate_limited(run, float(max_step[j]))
            bwd = _rate_limited(run[::-1], float(max_step[j]))[::-1]
            out[start:stop, j] = (fwd + bwd) / 2
    return out


def out_of_reach(angles: np.ndarray, profile: pepper.RobotProfile) -> np.ndarray:
    """`(N, D)` True where a (continuous, unlimited) angle lies beyond the robot's limits."""
    a = np.asarray(angles, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return np.asarray((a < profile.lower) | (a > profile.upper))
