"""Signal processing shared by the dataset builder and the robot side
(docs/architecture.md "Data flow").

Pure functions over arrays, radians and seconds inside:

- `interpolate_at` / `fill_gaps` / `resample_to_clock`: linear interpolation of irregularly
  timed samples (variable frame rate is real) onto given times, bridging short gaps only.
- `unwrap_angles` / `wrap_angles`: angles made continuous across ±π before they are
  interpolated or filtered (an angle beyond the robot's range steps from +π to −π), and back.
- `butter_lowpass`: the dissertation's zero-phase 5th-order Butterworth low-pass (§4.2.3).
- `KalmanConstAcc` / `kalman_const_acc`: the online constant-acceleration Kalman filter of the
  dissertation's live mode (§4.4.2), vectorised over joints.
- `OneEuro` / `one_euro`: the speed-adaptive one-euro low-pass (Casiez et al. 2012) on the
  samples' own timestamps, vectorised over values (landmark smoothing of the detectors).

Clamping and [0, 1] normalisation to the robot's limits (Eq. 3.13–3.14) live in
`gesturebank.robot.pepper`, not here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal

from gesturebank.errors import InputError

FloatArray = NDArray[np.floating]

# An interval between two valid samples counts as a "gap" in the report when it hides NaN
# samples or is this much longer than the stream's median frame spacing (a dropped frame).
_DROPPED_FRAME_FACTOR = 1.5


@dataclass(frozen=True)
class GapReport:
    """What interpolation had to bridge, summed over columns.

    A gap is a stretch of one column without valid samples that hides NaN samples or is longer
    than 1.5 × the median frame interval (dropped frames); the stretch from the clock's start to
    the first valid sample (and from the last one to the clock's end) counts too.

    gaps_filled:   gaps no longer than max_gap_s, interpolated (or held at an edge).
    gaps_unfilled: gaps longer than max_gap_s, left NaN (a column with no data counts once).
    longest_gap_s: longest gap of any column, filled or not, seconds (0.0 when there is none).
    missing_fraction: fraction of output values that are NaN.
    """

    gaps_filled: int
    gaps_unfilled: int
    longest_gap_s: float
    missing_fraction: float


def _rate(rate_hz: float, name: str = "rate_hz") -> float:
    rate = float(rate_hz)
    if not np.isfinite(rate) or rate <= 0:
        raise InputError(f"{name} must be a finite positive number, got {rate_hz!r}")
    return rate


def _values_2d(values: ArrayLike, name: str = "values") -> FloatArray:
    arr = np.asarray(values)
    if arr.ndim != 2:
        raise InputError(f"{name} must have shape (T, D), got shape {arr.shape}")
    if not np.issubdtype(arr.dtype, np.floating):
        arr = arr.astype(np.float64)
    return arr


def _timestamps(timestamps: ArrayLike, n: int) -> NDArray[np.float64]:
    ts = np.asarray(timestamps, dtype=np.float64)
    if ts.ndim != 1 or len(ts) != n:
        raise InputError(f"timestamps must have shape ({n},), got shape {ts.shape}")
    if n < 2:
        raise InputError(f"need at least 2 samples to interpolate, got {n}")
    if not np.all(np.isfinite(ts)):
        raise InputError("timestamps must all be finite")
    if np.any(np.diff(ts) <= 0):
        raise InputError("timestamps must be strictly increasing")
    return ts


def _interp_column(
    times: NDArray[np.float64],
    column: FloatArray,
    query: NDArray[np.float64],
    max_gap_s: float,
    dropped_s: float,
) -> tuple[NDArray[np.float64], list[float], list[float]]:
    """One column onto `query`; returns (values, filled gap lengths, unfilled gap lengths)."""
    valid = np.flatnonzero(np.isfinite(column))
    span = float(query[-1] - query[0])
    if len(valid) == 0:
        return np.full(len(query), np.nan), [], [span]
    tv, vv = times[valid], column[valid].astype(np.float64)
    out = np.interp(query, tv, vv)  # holds the end values beyond the first/last sample
    filled: list[float] = []
    unfilled: list[float] = []

    # Interior: the interval between valid samples k-1 and k (k = 1 .. len-1).
    lengths = np.diff(tv)
    hides_nan = np.diff(valid) > 1
    too_long = lengths > max_gap_s
    is_gap = hides_nan | too_long | (lengths > dropped_s)
    overlaps = (tv[1:] > query[0]) & (tv[:-1] < query[-1])
    for length, long_ in zip(lengths[is_gap & overlaps], too_long[is_gap & overlaps], strict=True):
        (unfilled if long_ else filled).append(float(length))
    if np.any(too_long):
        k = np.searchsorted(tv, query, side="left")  # tv[k-1] < q <= tv[k]
        inside = (k > 0) & (k < len(tv))
        strictly = inside & (tv[np.minimum(k, len(tv) - 1)] != query)
        bad = np.zeros(len(query), dtype=bool)
        bad[strictly] = too_long[k[strictly] - 1]
        out[bad] = np.nan

    # Edges: from the first query time to the first valid sample (and the same at the end).
    for before, edge_len, nan_inside in (
        (query < tv[0], tv[0] - query[0], valid[0] > 0),
        (query > tv[-1], query[-1] - tv[-1], valid[-1] < len(column) - 1),
    ):
        if not np.any(before):
            continue
        if edge_len > max_gap_s:
            out[before] = np.nan
            unfilled.append(float(edge_len))
        elif nan_inside or edge_len > dropped_s:
            filled.append(float(edge_len))
    return out, filled, unfilled


def interpolate_at(
    values: ArrayLike,
    timestamps: ArrayLike,
    *,
    query: ArrayLike,
    max_gap_s: float,
) -> tuple[FloatArray, GapReport]:
    """Linear interpolation of `values (T, D)` at `timestamps (T,)` onto `query (N,)` times.

    Each column is handled alone: its NaN samples are dropped and it is interpolated between its
    own valid samples, so one missing joint never removes the others. Between two valid samples
    further apart than `max_gap_s` (a NaN run or a hole in the timestamps) the result is NaN.
    Before the first / after the last valid sample the nearest value is held when that edge is no
    longer than `max_gap_s`, else NaN. Returns `(values (N, D), report)`, values in the input's
    float dtype.
    """
    arr = _values_2d(values)
    ts = _timestamps(timestamps, len(arr))
    q = np.asarray(query, dtype=np.float64)
    if q.ndim != 1 or len(q) == 0 or not np.all(np.isfinite(q)):
        raise InputError(f"query times must be a non-empty finite (N,) array, got {q.shape}")
    if np.any(np.diff(q) < 0):
        raise InputError("query times must be sorted")
    if not np.isfinite(max_gap_s) or max_gap_s < 0:
        raise InputError(f"max_gap_s must be finite and >= 0, got {max_gap_s!r}")
    dropped_s = _DROPPED_FRAME_FACTOR * float(np.median(np.diff(ts)))

    out = np.empty((len(q), arr.shape[1]), dtype=np.float64)
    filled: list[float] = []
    unfilled: list[float] = []
    for j in range(arr.shape[1]):
        out[:, j], f, u = _interp_column(ts, arr[:, j], q, float(max_gap_s), dropped_s)
        filled += f
        unfilled += u
    report = GapReport(
        gaps_filled=len(filled),
        gaps_unfilled=len(unfilled),
        longest_gap_s=max(filled + unfilled, default=0.0),
        missing_fraction=float(np.mean(np.isnan(out))) if out.size else 0.0,
    )
    return out.astype(arr.dtype, copy=False), report


def fill_gaps(
    values: ArrayLike, timestamps: ArrayLike, *, max_gap_s: float
) -> tuple[FloatArray, GapReport]:
    """Fill NaN runs of `values (T, D)` no longer than `max_gap_s` in place of time.

    The same rules as `interpolate_at` with the query being the samples' own `timestamps (T,)`.
    """
    return interpolate_at(values, timestamps, query=timestamps, max_gap_s=max_gap_s)


def clock(t0: float, t1: float, *, rate_hz: float) -> NDArray[np.float64]:
    """Uniform clock `(N,)`: frame i at t0 + i / rate_hz, for every frame with time <= t1."""
    rate = _rate(rate_hz)
    if not (np.isfinite(t0) and np.isfinite(t1)) or t1 < t0:
        raise InputError(f"clock needs finite t0 <= t1, got t0={t0!r}, t1={t1!r}")
    n = int(np.floor((t1 - t0) * rate + 1e-9)) + 1  # tolerance: t1 exactly on a tick counts
    return t0 + np.arange(n) / rate


def resample_to_clock(
    values: ArrayLike,
    timestamps: ArrayLike,
    *,
    rate_hz: float,
    t0: float | None = None,
    t1: float | None = None,
    max_gap_s: float,
) -> tuple[NDArray[np.float64], FloatArray, GapReport]:
    """Resample `values (T, D)` taken at irregular `timestamps (T,)` onto a uniform clock.

    Frame i of the result is at time t0 + i / rate_hz (the 100 Hz audio frame clock when t0 is
    the audio's start, usually 0.0), up to and including t1. t0 and t1 default to the first and
    last timestamps. Gap rules are those of `interpolate_at`. Returns
    `(times (N,), values (N, D), report)`.
    """
    arr = _values_2d(values)
    ts = _timestamps(timestamps, len(arr))
    times = clock(
        float(ts[0]) if t0 is None else float(t0),
        float(ts[-1] if t1 is None else t1),
        rate_hz=rate_hz,
    )
    out, report = interpolate_at(arr, ts, query=times, max_gap_s=max_gap_s)
    return times, out, report


def unwrap_angles(angles: ArrayLike) -> NDArray[np.float64]:
    """`angles (T, D)` rad with each column's steps across ±π undone, over its known values
    (NaN stays NaN; the step over a gap is undone too, so the gap is bridged the short way)."""
    out = np.array(angles, dtype=np.float64, copy=True)
    for col in out.reshape(len(out), -1).T:
        known = np.isfinite(col)
        col[known] = np.unwrap(col[known])
    return out


def wrap_angles(angles: ArrayLike) -> NDArray[np.float64]:
    """`angles` rad brought back into [−π, π]; those already inside are returned unchanged
    (bit for bit: no round trip through a modulo)."""
    a = np.asarray(angles, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return np.where(np.abs(a) > np.pi, np.mod(a + np.pi, 2 * np.pi) - np.pi, a)


def _finite_runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """[start, stop) of each run of True in a 1-D boolean mask."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def butter_lowpass(
    values: ArrayLike,
    rate_hz: float,
    *,
    cutoff_hz: float,
    order: int,
) -> FloatArray:
    """Zero-phase Butterworth low-pass of `values (N, D)` sampled at `rate_hz` (§4.2.3); the
    dissertation's is `processing.cutoff_hz` 4 Hz, `processing.butter_order` 5.

    The filter runs forward and backward (as the dissertation's filtfilt did), so there is no
    phase shift and the magnitude response is squared: −6 dB at the cut-off instead of −3 dB.
    It is designed in second-order sections, which stay stable at high orders / low cut-offs.

    Each column is filtered per contiguous run of finite values; NaN samples stay NaN and split
    the runs. A run needs more than scipy's default edge padding (3 × (2 × sections + 1) minus
    one per zero coefficient; 18 samples for order 5) to use it; shorter runs are filtered with
    the padding reduced to (run length − 1), and a single sample is left as it is. Returns an
    array of the input's float dtype.
    """
    arr = _values_2d(values)
    rate = _rate(rate_hz)
    cutoff = _rate(cutoff_hz, "cutoff_hz")
    if cutoff >= rate / 2:
        raise InputError(f"cutoff_hz ({cutoff}) must be below half of rate_hz ({rate})")
    if int(order) != order or order < 1:
        raise InputError(f"order must be a positive integer, got {order!r}")
    sos = signal.butter(int(order), cutoff, btype="low", fs=rate, output="sos")
    full_pad = 3 * (
        2 * len(sos) + 1 - min(int(np.sum(sos[:, 2] == 0)), int(np.sum(sos[:, 5] == 0)))
    )

    out = arr.astype(np.float64)
    for j in range(out.shape[1]):
        for start, stop in _finite_runs(np.isfinite(out[:, j])):
            n = stop - start
            if n < 2:
                continue
            pad = full_pad if n > full_pad else n - 1
            out[start:stop, j] = signal.sosfiltfilt(sos, out[start:stop, j], padlen=pad)
    return out.astype(arr.dtype, copy=False)


class KalmanConstAcc:
    """Online Kalman filter with a constant-acceleration model per joint (dissertation §4.4.2).

    State per joint [θ, θ̇, θ̈]; transition F = [[1, dt, dt²/2], [0, 1, dt], [0, 0, 1]];
    measurement H = [1, 0, 0]; process noise Q = diag(0, 0, q); measurement noise r. Defaults
    (q = 0.5, r = 0.01, dt = 0.01 s, P0 = I) are those of the dissertation's online code. All
    joints are filtered at once; each step is predict then update. A NaN measurement skips that
    joint's update (predict only), so a dropped value coasts on the model.
    """

    def __init__(
        self,
        n_joints: int,
        *,
        dt: float = 0.01,
        q: float = 0.5,
        r: float = 0.01,
        x0: ArrayLike | None = None,
    ) -> None:
        if int(n_joints) != n_joints or n_joints < 1:
            raise InputError(f"n_joints must be a positive integer, got {n_joints!r}")
        for name, value in (("dt", dt), ("q", q), ("r", r)):
            if not np.isfinite(value) or value < 0 or (name != "q" and value == 0):
                raise InputError(f"{name} must be finite and positive, got {value!r}")
        d = int(n_joints)
        self.F = np.array([[1.0, dt, dt * dt / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
        self.Q = np.diag([0.0, 0.0, float(q)])
        self.r = float(r)
        self.x = np.zeros((d, 3))  # (D, 3) state per joint
        if x0 is not None:
            start = np.asarray(x0, dtype=np.float64)
            if start.shape != (d,) or not np.all(np.isfinite(start)):
                raise InputError(f"x0 must be a finite ({d},) array, got shape {start.shape}")
            self.x[:, 0] = start
        self.P = np.tile(np.eye(3), (d, 1, 1))  # (D, 3, 3) covariance per joint

    def step(self, z: ArrayLike) -> NDArray[np.float64]:
        """Feed one measurement `z (D,)`; returns the filtered positions `(D,)`."""
        meas = np.asarray(z, dtype=np.float64)
        if meas.shape != (len(self.x),):
            raise InputError(f"measurement must have shape ({len(self.x)},), got {meas.shape}")
        # Predict: x = F x, P = F P Fᵀ + Q.
        self.x = self.x @ self.F.T
        self.P = self.F @ self.P @ self.F.T + self.Q
        # Update with H = [1, 0, 0]: S = P[0, 0] + r, K = P[:, 0] / S.
        ok = np.isfinite(meas)
        gain = self.P[:, :, 0] / (self.P[:, 0, 0] + self.r)[:, None]  # (D, 3)
        innovation = np.where(ok, meas - self.x[:, 0], 0.0)
        self.x = self.x + gain * innovation[:, None]
        # P = (I − K H) P, i.e. P − K ⊗ (row 0 of P); skipped where the measurement is NaN.
        updated = self.P - gain[:, :, None] * self.P[:, None, 0, :]
        self.P = np.where(ok[:, None, None], updated, self.P)
        return self.x[:, 0].copy()


def kalman_const_acc(
    values: ArrayLike,
    *,
    dt: float = 0.01,
    q: float = 0.5,
    r: float = 0.01,
    x0: ArrayLike | None = None,
) -> FloatArray:
    """Run `KalmanConstAcc` over `values (N, D)` row by row; returns the filtered `(N, D)`.

    x0 defaults to the first row (with NaN as 0) so the filter does not start from zero.
    """
    arr = _values_2d(values)
    if len(arr) == 0:
        raise InputError("values must have at least one row")
    start = np.nan_to_num(arr[0].astype(np.float64)) if x0 is None else x0
    kf = KalmanConstAcc(arr.shape[1], dt=dt, q=q, r=r, x0=start)
    out = np.empty(arr.shape, dtype=np.float64)
    for i, row in enumerate(arr):
        out[i] = kf.step(row)
    return out.astype(arr.dtype, copy=False)


def _alpha(cutoff_hz: FloatArray | float, dt: float) -> FloatArray:
    """Smoothing factor of a first-order low-pass at `cutoff_hz` for a step of `dt` seconds:
    α = 1 / (1 + τ / dt), τ = 1 / (2π f_c) (Casiez et al. 2012)."""
    tau = 1.0 / (2.0 * np.pi * np.asarray(cutoff_hz, dtype=np.float64))
    return 1.0 / (1.0 + tau / dt)


class OneEuro:
    """One-euro filter (Casiez, Roussel & Vogel, CHI 2012), vectorised over any array of values.

    Each value is smoothed by an exponential low-pass whose cut-off grows with its speed:
    f_c = min_cutoff + beta · |ẋ|, where ẋ is the speed (change per second, times `scale`)
    low-passed at `d_cutoff`. Slow values are smoothed hard (no jitter), fast ones barely (no
    lag). The speed comes from consecutive raw samples, as in the authors' reference code (and
    mediapipe's copy of it). Steps are timed by the samples' own timestamps, so variable frame
    rates need no resampling. The first sample passes unchanged; a NaN value comes out NaN and
    restarts that value's filter; a timestamp not after the last one returns the input as is.

    `scale` multiplies the speed (mediapipe divides pixel speeds by the person's size in pixels,
    so one beta suits near and far people).
    """

    def __init__(self, *, min_cutoff: float, beta: float, d_cutoff: float = 1.0) -> None:
        for name, value in (("min_cutoff", min_cutoff), ("d_cutoff", d_cutoff)):
            if not np.isfinite(value) or value <= 0:
                raise InputError(f"{name} must be finite and positive, got {value!r}")
        if not np.isfinite(beta) or beta < 0:
            raise InputError(f"beta must be finite and >= 0, got {beta!r}")
        self.min_cutoff = float(min_cutoff)
        self.beta = float(beta)
        self.d_cutoff = float(d_cutoff)
        self.reset()

    def reset(self) -> None:
        """Forget the past: the next sample passes unchanged."""
        self._state: _OneEuroState | None = None

    def step(self, value: ArrayLike, t: float, *, scale: float = 1.0) -> NDArray[np.float64]:
        """Filter one sample `value (...)` taken at `t` seconds; returns the smoothed `(...)`."""
        x = np.asarray(value, dtype=np.float64)
        s = self._state
        if s is None or s.raw.shape != x.shape:
            self._state = _OneEuroState(float(t), x, x.copy(), np.zeros_like(x))
            return x.copy()
        if not t > s.t:
            return x.copy()
        dt = t - s.t
        fresh = ~np.isfinite(s.raw)  # values restarting after a NaN
        speed = np.where(fresh, 0.0, (x - s.raw) * scale / dt)
        dx = np.where(fresh, speed, s.dx + _alpha(self.d_cutoff, dt) * (speed - s.dx))
        a = _alpha(self.min_cutoff + self.beta * np.abs(dx), dt)
        out = np.where(fresh, x, s.x + a * (x - s.x))
        self._state = _OneEuroState(float(t), x, out, dx)
        return out.copy()


@dataclass(frozen=True)
class _OneEuroState:
    """Last timestamp, raw sample, output and smoothed speed of a OneEuro filter."""

    t: float
    raw: NDArray[np.float64]
    x: NDArray[np.float64]
    dx: NDArray[np.float64]


def one_euro(
    values: ArrayLike,
    timestamps: ArrayLike,
    *,
    min_cutoff: float,
    beta: float,
    d_cutoff: float = 1.0,
    scale: ArrayLike = 1.0,
) -> FloatArray:
    """`OneEuro` over the rows of `values (T, ...)` taken at strictly increasing `timestamps (T,)`;
    `scale` is one number or `(T,)`. Returns the smoothed `(T, ...)` in the input's float dtype."""
    arr = np.asarray(values)
    if arr.ndim < 1 or len(arr) == 0:
        raise InputError(f"values must have at least one row, got shape {arr.shape}")
    ts = np.asarray(timestamps, dtype=np.float64)
    if ts.shape != arr.shape[:1] or not np.all(np.isfinite(ts)) or np.any(np.diff(ts) <= 0):
        raise InputError(f"timestamps must be ({len(arr)},), finite and strictly increasing")
    scales = np.broadcast_to(np.asarray(scale, dtype=np.float64), ts.shape)
    dtype = arr.dtype if np.issubdtype(arr.dtype, np.floating) else np.dtype(np.float64)
    f = OneEuro(min_cutoff=min_cutoff, beta=beta, d_cutoff=d_cutoff)
    out = np.stack([f.step(row, t, scale=s) for row, t, s in zip(arr, ts, scales, strict=True)])
    return out.astype(dtype, copy=False)
