"""Cutting a clip around the stretch that fails a check (issue 41): the checks of scope
"stretch" in `qc.table` (seen from the side, frozen at a limit, a glitch, no speech, ...) drop
that stretch, not the clip.

Each stretch check gives a per-video-frame `Signal`. Two kinds:

- an aggregate (a share of frames, a mean): the clip passes while Σ w·v / Σ w ≤ limit over its
  frames. The cut drops the worst one-second windows (largest Σ w·(v − limit)) until the rest
  passes: the least footage that brings the share under the limit.
- events (`events=True`): each frame whose value exceeds the limit fails by itself (a spike, a
  swap, the part of a frozen run beyond the limit); exactly those frames are dropped.

Around each dropped stretch a margin (`qc.stretch_margin_s`) goes too; what is left between the
cuts becomes clips again when it lasts at least `clips.min_s` (`judge`), each judged on its own
(a piece can fail again, and is cut again, `qc.stretch_rounds` times at most). A clip failing a
check of scope "take" is rejected whole, as before.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import fields, replace
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from gesturebank.clip import Clip
from gesturebank.config import QCConfig
from gesturebank.lift.clip_confidence import expected_hand_error_cm
from gesturebank.qc import metrics as M
from gesturebank.qc.checks import Failure, failures
from gesturebank.qc.clip_metrics import ClipMetrics
from gesturebank.qc.table import CHECKS, Check, Signal, StretchSignal
from gesturebank.robot.pepper import INDEX, RobotProfile
from gesturebank.skeletons import COCO17

F64 = NDArray[np.float64]
WINDOW_S = 1.0  # the aggregate cut's step: one second at a time
CUT = "cut: "  # the reason of a stretch cut out starts so, then the failed check's reason
BETWEEN_CUTS = "too short between cut stretches"


def is_cut_reason(reason: str) -> bool:
    """Whether `reason` is that of a stretch the QC cut out (or left too short between cuts)."""
    return reason.startswith((CUT, BETWEEN_CUTS))


def _at_frames(values: object, clip: Clip) -> np.ndarray:
    """`values (N, ...)` on the clip's 100 Hz clock → `(T, ...)` at its video frames (the
    sample at or after each frame's time)."""
    k = np.searchsorted(np.asarray(clip.times), np.asarray(clip.timestamps) - 1e-9)
    return np.asarray(values)[np.clip(k, 0, len(clip.times) - 1)]


def _share(bad: np.ndarray, counted: np.ndarray, limit: float) -> Signal:
    counted = np.asarray(counted, bool)
    return Signal(np.where(counted, np.asarray(bad, float), 0.0), counted.astype(float), limit)


def _events(bad: np.ndarray) -> Signal:
    b = np.asarray(bad, float)
    return Signal(b, np.ones(len(b)), 0.5, events=True)


def _unknown(clip: Clip, columns: list[int], limit: float) -> Signal:
    known = np.asarray(clip.mask, bool)[:, columns].any(axis=1)
    return _share(~_at_frames(known, clip), np.ones(len(clip.timestamps), bool), limit)


def _limit(config: QCConfig, field: str) -> float:
    value = getattr(config, field)
    return math.inf if value is None else float(value)


def head_unseen(clip: Clip, config: QCConfig, profile: RobotProfile) -> Signal:
    cols = [INDEX["HeadPitch"], INDEX["HeadYaw"]]
    return _unknown(clip, cols, _limit(config, "max_head_unknown_fraction"))


def arms_unseen(clip: Clip, config: QCConfig, profile: RobotProfile) -> Signal:
    cols = [INDEX["LShoulderPitch"], INDEX["RShoulderPitch"]]
    return _unknown(clip, cols, _limit(config, "max_arms_unknown_fraction"))


def _rate(clip: Clip) -> float:
    return 1.0 / float(np.median(np.diff(clip.times))) if len(clip.times) > 1 else 100.0


def beyond_reach(clip: Clip, config: QCConfig, profile: RobotProfile) -> Signal:
    beyond, _, _ = M.reach_frames(clip, profile=profile, qc=config, rate_hz=_rate(clip))
    frames = _at_frames(beyond.any(axis=1), clip)
    return _share(frames, np.ones(len(frames), bool), _limit(config, "max_limit_fraction"))


def frozen_at_limit(clip: Clip, config: QCConfig, profile: RobotProfile) -> Signal:
    """Events: of each run frozen at a limit while the person moves (`metrics.frozen_frames`)
    longer than qc.max_frozen_at_limit_s, its middle: what is left of the run either side is
    less than the limit, so each of the pieces it ends or starts passes."""
    rate = _rate(clip)
    _, held, person = M.reach_frames(clip, profile=profile, qc=config, rate_hz=rate)
    frozen = M.frozen_frames(held, person, rate_hz=rate, min_motion=config.frozen_min_motion,
                             window_s=config.frozen_motion_window_s)  # fmt: skip
    limit = math.floor(_limit(config, "max_frozen_at_limit_s") * rate) - 1  # samples, strictly
    bad = np.zeros(len(clip.times), bool)
    for j in range(frozen.shape[1]):
        for start, stop in _runs(frozen[:, j]):
            if stop - start > limit + 1:  # fails: keep at most `limit` samples at each end
                bad[start + limit : max(stop - limit, start + limit + 1)] = True
    return _events(_at_frames(bad, clip))


def jitter(clip: Clip, config: QCConfig, profile: RobotProfile) -> Signal:
    """Per one-second window of the analysis clock, its power above qc.jitter_above_hz (values:
    the window's share, weights: its whole power, so the weighted mean is the clip's share)."""
    hz = config.analysis_rate_hz
    raw = M.analysis_angles(clip, config)
    n = max(8, round(WINDOW_S * hz))
    t = np.asarray(clip.timestamps, float)
    values, weights = np.zeros(len(t)), np.zeros(len(t))
    for w0 in range(0, max(len(raw) - n + 1, 0), n):
        window = raw[w0 : w0 + n]
        if not np.isfinite(window).any():
            continue
        freqs, power = M.spectrum(window, hz)
        total = float(power[1:].sum())
        if total <= 0:
            continue
        high = float(power[freqs > config.jitter_above_hz].sum())
        inside = (t >= t[0] + w0 / hz) & (t < t[0] + (w0 + n) / hz)
        values[inside] = high / total
        weights[inside] = total / max(int(inside.sum()), 1)
    return Signal(values, weights, _limit(config, "max_jitter_fraction"))


def swaps(clip: Clip, config: QCConfig, profile: RobotProfile) -> Signal:
    """Events: the frames between a left/right exchange and its exchange back (within one
    second; a lone exchange: the frames either side of it)."""
    pts = M.judged_points(clip)
    steps = np.zeros(max(len(clip.timestamps) - 1, 0), bool)
    for p in pts.shapes:
        steps |= M.swap_steps(p)
    bad = np.zeros(len(clip.timestamps), bool)
    at = np.flatnonzero(steps) + 1  # the first frame after each exchange
    t = np.asarray(clip.timestamps, float)
    k = 0
    while k < len(at):
        if k + 1 < len(at) and t[at[k + 1]] - t[at[k]] <= WINDOW_S:
            bad[at[k] : at[k + 1]] = True
            k += 2
        else:
            bad[max(at[k] - 1, 0) : at[k] + 1] = True
            k += 1
    return _events(bad)


def spike(clip: Clip, config: QCConfig, profile: RobotProfile) -> Signal:
    """Events: the frames in which a keypoint jumps out and back more than qc.max_spike."""
    pts = M.judged_points(clip)
    bad = np.zeros(len(clip.timestamps), bool)
    for p in pts.shapes:
        sizes = M.spike_sizes(p)
        if len(sizes):
            with np.errstate(invalid="ignore"):
                bad[1:-1] |= np.nan_to_num(sizes, nan=0.0).max(axis=1) > config.max_spike
    return _events(bad)


def facing_away(clip: Clip, config: QCConfig, profile: RobotProfile) -> Signal:
    pts = M.judged_points(clip)
    away, _ = M.view_flags(pts)
    counted = pts.shoulders & ~M.is_mocap(clip)  # motion capture: no view to judge
    return _share(away, counted, config.max_facing_away_fraction)


def sideways(clip: Clip, config: QCConfig, profile: RobotProfile) -> Signal:
    pts = M.judged_points(clip)
    _, side = M.view_flags(pts)
    counted = pts.shoulders & pts.valid[:, COCO17.index["nose"]] & ~M.is_mocap(clip)
    return _share(side, counted, config.max_sideways_fraction)


def no_speech(clip: Clip, config: QCConfig, profile: RobotProfile) -> Signal:
    """The share without speech must stay at most 1 − qc.min_speech_fraction."""
    silent = ~_at_frames(np.asarray(clip.speech, bool), clip)
    low = config.min_speech_fraction
    return _share(silent, np.ones(len(silent), bool), 1.0 - (0.0 if low is None else low))


def depth_uncertain(clip: Clip, config: QCConfig, profile: RobotProfile) -> Signal:
    """Each frame's expected Pepper hand error (the clip's is their mean)."""
    t = len(clip.timestamps)
    if M.is_mocap(clip):
        values = np.zeros(t)
    else:
        lifter = clip.pose3d.meta.get("lifter", "")
        conf = np.asarray(clip.depth_confidence)
        values = np.array(
            [expected_hand_error_cm(confidence=conf[i : i + 1], lifter=lifter) for i in range(t)]
        )
    weights = np.isfinite(values).astype(float)
    limit = _limit(config, "max_expected_hand_error_cm")
    return Signal(np.nan_to_num(values), weights, limit)


# The signals of the built-in stretch checks, by check name (`qc.table`).
SIGNALS: dict[str, Callable[[Clip, QCConfig, RobotProfile], Signal]] = {
    "head_unseen": head_unseen,
    "arms_unseen": arms_unseen,
    "beyond_reach": beyond_reach,
    "frozen_at_limit": frozen_at_limit,
    "jitter": jitter,
    "swaps": swaps,
    "spike": spike,
    "facing_away": facing_away,
    "sideways": sideways,
    "no_speech": no_speech,
    "depth_uncertain": depth_uncertain,
}


def signal_of(check: Check) -> StretchSignal | None:
    """The per-frame signal a stretch check cuts by: its own, or a built-in one's."""
    return check.stretch or (SIGNALS.get(check.name) if check.scope == "stretch" else None)


# --------------------------------------------------------------------------------------------------
# Where to cut


def event_frames(signal: Signal) -> NDArray[np.bool_]:
    """`(T,)` the frames of an events signal that fail by themselves."""
    v, w = np.asarray(signal.values, float), np.asarray(signal.weights, float)
    return np.asarray((v > signal.limit) & (w > 0))


def excess(signal: Signal) -> F64:
    """`(T,)` each frame's part of an aggregate signal's excess: a run of frames passes the
    signal when their sum is at most 0."""
    v, w = np.asarray(signal.values, float), np.asarray(signal.weights, float)
    return np.asarray(w * (v - signal.limit))


def best_pieces(
    *, excesses: Sequence[np.ndarray], forbidden: np.ndarray, starts: np.ndarray,
    ends: np.ndarray, min_s: float,
) -> list[tuple[int, int]]:  # fmt: skip
    """The runs of frames [a, b) to keep that keep the most seconds, each at least `min_s`
    long (`ends[b − 1] − starts[a]`), holding no `forbidden` frame, and passing every signal
    whose per-frame `excesses` are given (their sum over the run at most 0). Dynamic
    programming over the frames: K[i] the most kept before frame i with frame i − 1 dropped,
    P[b] the most kept with a run ending at b."""
    n = len(starts)
    sums = [np.concatenate([[0.0], np.cumsum(e)]) for e in excesses]
    bad = np.concatenate([[0], np.cumsum(np.asarray(forbidden, np.int64))])
    dropped_best = np.zeros(n + 1)  # K[b]: frame b − 1 dropped (or b = 0)
    run_best = np.full(n + 1, -np.inf)  # P[b]: a run ends at b
    run_from = np.full(n + 1, -1, np.int64)
    for b in range(1, n + 1):
        dropped_best[b] = max(dropped_best[b - 1], run_best[b - 1])
        first = np.arange(b)
        seconds = ends[b - 1] - starts[first]
        ok = (seconds >= min_s - 1e-9) & (bad[b] - bad[first] == 0)
        for c in sums:
            ok &= c[b] - c[first] <= 1e-9
        if ok.any():
            value = np.where(ok, dropped_best[first] + seconds, -np.inf)
            i = int(np.argmax(value))
            run_best[b], run_from[b] = value[i], i
    pieces: list[tuple[int, int]] = []
    b, in_run = n, bool(run_best[n] > dropped_best[n])
    while b > 0:
        if in_run:
            a = int(run_from[b])
            pieces.append((a, b))
            b, in_run = a, False
        else:
            in_run = bool(run_best[b - 1] > dropped_best[b - 1])
            b -= 1
    return sorted(pieces)


class Plan(NamedTuple):
    """Frames [a, b) of the clip to keep, and those dropped with their reasons."""

    kept: list[tuple[int, int]]
    dropped: list[tuple[int, int, str]]


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.diff(np.concatenate([[0], np.asarray(mask, np.int8), [0]]))
    return [
        (int(a), int(b))
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True)
    ]


def _ends(t: np.ndarray) -> np.ndarray:
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    return np.append(t[1:], t[-1] + dt)


def plan_cut(
    clip: Clip,
    failed: Sequence[Failure],
    *,
    config: QCConfig,
    profile: RobotProfile,
    min_s: float,
) -> Plan:
    """Where to cut `clip`: the most seconds in pieces of at least `min_s` that hold none of
    the failing frames of the event checks of `failed` (with qc.stretch_margin_s either side)
    and pass every stretch check whose limit is set (`best_pieces`, so a piece does not pass
    one check only to fail another). Each dropped run is named by the failed check that wants
    it most (events first)."""
    t = np.asarray(clip.timestamps, float)
    ends = _ends(t)
    forbidden = np.zeros(len(t), bool)
    why = np.full(len(t), "", dtype=object)
    failing = {f.check.name: f for f in failed if f.check is not None and signal_of(f.check)}
    shares: list[tuple[Failure | None, F64]] = []
    for check in CHECKS:
        make = signal_of(check)
        if make is None or check.limit(config) is None:
            continue
        signal = make(clip, config, profile)
        failure = failing.get(check.name)
        if not signal.events:
            shares.append((failure, excess(signal)))
            continue
        if failure is None:
            continue
        for a, b in _runs(event_frames(signal)):
            lo = np.searchsorted(t, t[a] - config.stretch_margin_s, side="left")
            hi = np.searchsorted(t, ends[b - 1] + config.stretch_margin_s, side="left")
            forbidden[lo:hi] = True
            free = why[lo:hi] == ""
            why[lo:hi][free] = f"{CUT}{failure.reason}"
    kept = best_pieces(
        excesses=[e for _, e in shares], forbidden=forbidden, starts=t, ends=ends, min_s=min_s
    )
    keep = np.zeros(len(t), bool)
    for a, b in kept:
        keep[a:b] = True
    dropped = []
    for a, b in _runs(~keep):
        for p, q in _same(why[a:b]):
            reason = str(why[a + p])
            if not reason:  # the share check most over its limit there
                worst = max(shares, key=lambda fe: float(fe[1][a + p : a + q].sum()))
                f = worst[0] or next(iter(failing.values()), None)
                reason = f"{CUT}{f.reason}" if f is not None else f"{BETWEEN_CUTS}"
            dropped.append((a + p, a + q, reason))
    return Plan(kept, dropped)


def _same(values: np.ndarray) -> list[tuple[int, int]]:
    """[p, q) runs of equal values."""
    change = [0, *[i for i in range(1, len(values)) if values[i] != values[i - 1]], len(values)]
    return list(itertools.pairwise(change))


# --------------------------------------------------------------------------------------------------
# A piece of a clip, and the judging loop


def piece(clip: Clip, start: int, *, stop: int, clip_id: str) -> Clip:
    """Video frames [start, stop) of `clip` as a clip of its own: the 100 Hz samples between
    their first and last frame (as the build's audio clock takes them), its clock's 0 on the
    first of those."""
    ts = np.asarray(clip.timestamps, float)
    times = np.asarray(clip.times, float)
    eps = 1e-9
    i0 = int(np.searchsorted(times, ts[start] - eps, side="left"))
    i1 = int(np.searchsorted(times, ts[stop - 1] + eps, side="right"))
    if i1 <= i0:
        raise ValueError(f"clip {clip.clip_id}: frames {start}..{stop} hold no 100 Hz sample")
    origin = float(times[i0])
    n, t = slice(i0, i1), slice(start, stop)
    cut: dict[str, object] = {
        "clip_id": clip_id,
        "start_s": clip.start_s + origin,
        "times": times[n] - origin,
        "timestamps": ts[t] - origin,
        "pose2d": clip.pose2d.frames(start, stop, origin_s=origin),
        "pose3d": clip.pose3d.frames(start, stop, origin_s=origin),
    }
    # every other array: on the 100 Hz clock (N rows) or on the video frames (T rows)
    rows_n, rows_t = len(times), len(ts)
    for f in fields(clip):
        value = getattr(clip, f.name)
        if f.name in cut or not isinstance(value, np.ndarray) or value.ndim == 0:
            continue
        if rows_n == rows_t:
            raise ValueError(f"clip {clip.clip_id}: as many video frames as 100 Hz samples")
        if len(value) == rows_n:
            cut[f.name] = value[n]
        elif len(value) == rows_t:
            cut[f.name] = value[t]
    return replace(clip, **cut)  # type: ignore[arg-type]


class Judged(NamedTuple):
    """One outcome of `judge`: a clip with its metrics and reasons (accepted when there are
    none), or a dropped stretch (clip None) from start_s to end_s of the take with its reason."""

    start_s: float
    end_s: float
    clip: Clip | None
    metrics: ClipMetrics | None
    reasons: tuple[str, ...]


def judge(
    clip: Clip,
    *,
    measure: Callable[[Clip], ClipMetrics],
    config: QCConfig,
    profile: RobotProfile,
    min_s: float,
    rounds: int | None = None,
) -> list[Judged]:
    """`clip` judged by the absolute checks: accepted; rejected whole (a check of scope "take"
    failed, or cutting would leave no piece of min_s); or cut around the stretches that fail
    (`plan_cut`) and its pieces judged the same way, `rounds` (qc.stretch_rounds) times at
    most. Pieces are named `<clip_id>.<k>`; the caller renames them. In the take's time order."""
    rounds = config.stretch_rounds if rounds is None else rounds
    metrics = measure(clip)
    failed = failures(metrics, config)
    t = np.asarray(clip.timestamps, float)
    ends = _ends(t)
    whole = Judged(
        clip.start_s + float(t[0]),
        clip.start_s + float(ends[-1]),
        clip,
        metrics,
        tuple(f.reason for f in failed),
    )
    if not failed or rounds <= 0 or any(f.scope == "take" for f in failed):
        return [whole]
    plan = plan_cut(clip, failed, config=config, profile=profile, min_s=min_s)
    if not plan.kept or not any(r.startswith(CUT) for _, _, r in plan.dropped):
        # no stretch stands out, or nothing of min_s is left: the clip fails as a whole (kept,
        # rejected, so looser thresholds can admit it again)
        return [whole]
    out = [
        Judged(clip.start_s + float(t[a]), clip.start_s + float(ends[b - 1]), None, None, (r,))
        for a, b, r in plan.dropped
    ]
    for k, (a, b) in enumerate(plan.kept):
        part = piece(clip, a, stop=b, clip_id=f"{clip.clip_id}.{k}")
        out += judge(
            part, measure=measure, config=config, profile=profile, min_s=min_s, rounds=rounds - 1
        )
    return sorted(out, key=lambda j: j.start_s)
