"""Tests of gesturebank.filters on signals whose right answer is known in closed form."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import solve_discrete_are

from gesturebank.errors import InputError
from gesturebank.filters import (
    KalmanConstAcc,
    OneEuro,
    butter_lowpass,
    fill_gaps,
    kalman_const_acc,
    one_euro,
    resample_to_clock,
)

RATE = 100.0
LOWPASS = {"cutoff_hz": 4.0, "order": 5}  # the dissertation's (§4.2.3)


# --- Butterworth ------------------------------------------------------------------------------


def _sine_response(freq_hz: float) -> tuple[float, float]:
    """Gain (dB) and phase shift (rad) of butter_lowpass on a 60 s sine, fitted mid-signal."""
    t = np.arange(int(60 * RATE)) / RATE
    x = np.sin(2 * np.pi * freq_hz * t + 0.3)
    y = butter_lowpass(x[:, None], RATE, cutoff_hz=4.0, order=5)[:, 0]
    mid = slice(len(t) // 4, 3 * len(t) // 4)  # well away from the edge transients
    basis = np.column_stack(
        [np.sin(2 * np.pi * freq_hz * t[mid]), np.cos(2 * np.pi * freq_hz * t[mid])]
    )
    (a_in, b_in), *_ = np.linalg.lstsq(basis, x[mid], rcond=None)
    (a_out, b_out), *_ = np.linalg.lstsq(basis, y[mid], rcond=None)
    gain_db = 20 * np.log10(np.hypot(a_out, b_out) / np.hypot(a_in, b_in))
    phase = np.angle(complex(a_out, b_out) / complex(a_in, b_in))
    return float(gain_db), float(phase)


def test_butterworth_is_minus_6_db_at_the_cutoff() -> None:
    # Forward and backward: |H|² at the −3 dB point of one pass is −6.02 dB.
    gain_db, phase = _sine_response(4.0)
    assert -6.5 <= gain_db <= -5.5
    assert abs(phase) < 1e-3


def test_butterworth_passes_1_hz_unchanged_without_phase_shift() -> None:
    gain_db, phase = _sine_response(1.0)
    assert abs(10 ** (gain_db / 20) - 1) < 0.01
    assert abs(phase) < 1e-3  # zero-phase; one forward pass would lag by ~0.4 rad here


def test_butterworth_attenuates_10_hz_by_more_than_40_db() -> None:
    gain_db, _ = _sine_response(10.0)
    assert gain_db < -40


def test_butterworth_filters_each_finite_run_alone_and_keeps_nan() -> None:
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=200), rng.normal(size=150)
    col = np.concatenate([a, [np.nan] * 10, b])
    other = rng.normal(size=len(col))
    out = butter_lowpass(np.column_stack([col, other]), RATE, **LOWPASS)
    assert np.all(np.isnan(out[200:210, 0]))
    np.testing.assert_allclose(out[:200, 0], butter_lowpass(a[:, None], RATE, **LOWPASS)[:, 0])
    np.testing.assert_allclose(out[210:, 0], butter_lowpass(b[:, None], RATE, **LOWPASS)[:, 0])
    # The NaN in column 0 does not touch column 1.
    np.testing.assert_allclose(out[:, 1], butter_lowpass(other[:, None], RATE, **LOWPASS)[:, 0])


def test_butterworth_short_runs_stay_finite_and_keep_constants() -> None:
    col = np.array([0.7] * 5 + [np.nan] + [0.2] + [np.nan] + [-0.4] * 12)
    out = butter_lowpass(col[:, None], RATE, **LOWPASS)[:, 0]
    np.testing.assert_allclose(out[:5], 0.7)  # unity DC gain even with reduced padding
    assert out[6] == pytest.approx(0.2)  # a single sample is left as it is
    np.testing.assert_allclose(out[8:], -0.4)
    assert np.isnan(out[5]) and np.isnan(out[7])


def test_butterworth_keeps_float32() -> None:
    out = butter_lowpass(np.zeros((50, 3), dtype=np.float32), RATE, **LOWPASS)
    assert out.dtype == np.float32 and out.shape == (50, 3)


@pytest.mark.parametrize(
    ("values", "rate", "cutoff"),
    [(np.zeros(50), RATE, 4.0), (np.zeros((50, 2)), np.nan, 4.0), (np.zeros((50, 2)), RATE, 50.0)],
)
def test_butterworth_rejects_bad_input(values: np.ndarray, rate: float, cutoff: float) -> None:
    with pytest.raises(InputError):
        butter_lowpass(values, rate, cutoff_hz=cutoff, order=5)


# --- Resampling -------------------------------------------------------------------------------


def _vfr_timestamps(duration_s: float, seed: int = 1) -> np.ndarray:
    """Variable frame rate: each frame interval drawn between 1/35 s and 1/25 s."""
    rng = np.random.default_rng(seed)
    dt = rng.uniform(1 / 35, 1 / 25, size=int(duration_s * 35))
    ts = np.concatenate([[0.0], np.cumsum(dt)])
    return ts[ts <= duration_s]


def test_resample_vfr_smooth_function_to_interpolation_accuracy() -> None:
    ts = _vfr_timestamps(10.0)
    f = lambda t: np.sin(2 * np.pi * 0.5 * t) + 0.3 * t  # noqa: E731
    lin = lambda t: 2.0 - 0.7 * t  # noqa: E731
    times, out, report = resample_to_clock(
        np.column_stack([f(ts), lin(ts)]), ts, rate_hz=RATE, max_gap_s=0.25
    )
    np.testing.assert_allclose(times, ts[0] + np.arange(len(times)) / RATE, atol=1e-12)
    assert times[-1] <= ts[-1] < times[-1] + 1 / RATE
    # Linear interpolation error bound: max|f''| h² / 8 with h the longest frame interval.
    bound = (np.pi**2) * np.max(np.diff(ts)) ** 2 / 8
    assert np.max(np.abs(out[:, 0] - f(times))) <= bound
    np.testing.assert_allclose(out[:, 1], lin(times), atol=1e-12)  # exact for a line
    assert report.gaps_unfilled == 0 and report.missing_fraction == 0.0


def test_resample_fills_short_gap_and_leaves_long_gap_nan() -> None:
    ts = np.arange(0, 10, 1 / 30)
    lin = 1.0 + 0.5 * ts
    col = lin.copy()
    col[(ts > 2.0) & (ts < 2.1)] = np.nan  # ~0.1 s hole: filled
    col[(ts > 5.0) & (ts < 5.6)] = np.nan  # ~0.6 s hole: left NaN
    times, out, report = resample_to_clock(
        np.column_stack([col, lin]), ts, rate_hz=RATE, t0=0.0, max_gap_s=0.25
    )
    last_before = ts[ts <= 5.0][-1]
    first_after = ts[ts >= 5.6][0]
    in_long = (times > last_before + 1e-9) & (times < first_after - 1e-9)
    assert np.all(np.isnan(out[in_long, 0]))
    np.testing.assert_allclose(out[~in_long, 0], 1.0 + 0.5 * times[~in_long], atol=1e-9)
    # Per-column independence: the other column is complete and exact.
    np.testing.assert_allclose(out[:, 1], 1.0 + 0.5 * times, atol=1e-9)
    assert report.gaps_filled == 1
    assert report.gaps_unfilled == 1
    assert report.longest_gap_s == pytest.approx(first_after - last_before)


def test_resample_timestamp_hole_without_nan() -> None:
    ts = np.arange(0, 4, 0.04)
    ts = np.concatenate([ts[ts < 1.0], ts[ts > 1.5]])  # frames dropped for ~0.5 s
    times, out, report = resample_to_clock((3 * ts)[:, None], ts, rate_hz=RATE, max_gap_s=0.25)
    hole = (times > ts[ts < 1.0][-1] + 1e-9) & (times < ts[ts > 1.5][0] - 1e-9)
    assert hole.sum() > 40 and np.all(np.isnan(out[hole, 0]))
    np.testing.assert_allclose(out[~hole, 0], 3 * times[~hole], atol=1e-9)
    assert (report.gaps_filled, report.gaps_unfilled) == (0, 1)


def test_resample_edges_held_when_short_nan_when_long() -> None:
    ts = np.arange(0.02, 3.0, 0.04)
    vals = np.column_stack([np.full(len(ts), 0.5), np.full(len(ts), -0.5)])
    times, out, _ = resample_to_clock(vals, ts, rate_hz=RATE, t0=0.0, t1=3.0, max_gap_s=0.25)
    assert times[0] == 0.0 and np.all(np.isfinite(out))  # 20 ms lead: held
    times, out, report = resample_to_clock(vals, ts, rate_hz=RATE, t0=-1.0, max_gap_s=0.25)
    lead = times < ts[0]
    assert np.all(np.isnan(out[lead])) and np.all(np.isfinite(out[~lead]))
    assert report.gaps_unfilled == 2  # one per column
    assert report.longest_gap_s == pytest.approx(1.02)


def test_resample_column_without_data_is_nan_and_others_survive() -> None:
    ts = np.arange(0, 1, 0.05)
    vals = np.column_stack([np.full(len(ts), np.nan), ts])
    _, out, report = resample_to_clock(vals, ts, rate_hz=RATE, max_gap_s=0.25)
    assert np.all(np.isnan(out[:, 0])) and np.all(np.isfinite(out[:, 1]))
    assert report.gaps_unfilled == 1
    assert report.missing_fraction == pytest.approx(0.5)


def test_fill_gaps_on_own_timestamps() -> None:
    ts = np.arange(0, 2, 0.02)
    col = np.sin(ts)
    col[10:13] = np.nan
    out, report = fill_gaps(col[:, None], ts, max_gap_s=0.25)
    np.testing.assert_allclose(
        out[:, 0], np.interp(ts, ts[np.isfinite(col)], col[np.isfinite(col)])
    )
    assert np.all(np.isfinite(out)) and report.gaps_filled == 1


@pytest.mark.parametrize(
    ("values", "ts", "rate"),
    [
        (np.zeros((5, 2)), np.array([0.0, 0.1, 0.1, 0.2, 0.3]), RATE),  # not increasing
        (np.zeros((5, 2)), np.arange(4) * 0.1, RATE),  # length mismatch
        (np.zeros(5), np.arange(5) * 0.1, RATE),  # not (T, D)
        (np.zeros((5, 2)), np.arange(5) * 0.1, float("inf")),
        (np.zeros((5, 2)), np.array([0.0, 0.1, np.nan, 0.3, 0.4]), RATE),
    ],
)
def test_resample_rejects_bad_input(values: np.ndarray, ts: np.ndarray, rate: float) -> None:
    with pytest.raises(InputError):
        resample_to_clock(values, ts, rate_hz=rate, max_gap_s=0.25)


# --- Kalman -----------------------------------------------------------------------------------

DT, Q, R = 0.01, 0.5, 0.01
F = np.array([[1, DT, DT**2 / 2], [0, 1, DT], [0, 0, 1]])
H = np.array([[1.0, 0.0, 0.0]])
QM = np.diag([0.0, 0.0, Q])


def test_kalman_converges_to_noiseless_constant_acceleration() -> None:
    t = np.arange(600) * DT
    theta0, v, a = np.array([0.3, -1.0]), np.array([0.5, 0.2]), np.array([-0.8, 1.5])
    truth = theta0 + v * t[:, None] + a * t[:, None] ** 2 / 2
    kf = KalmanConstAcc(2)  # starts at zero, as the dissertation's online filter did
    est = np.array([kf.step(z) for z in truth])
    np.testing.assert_allclose(est[-50:], truth[-50:], atol=1e-6)
    np.testing.assert_allclose(kf.x[:, 1], v + a * t[-1], atol=1e-3)  # velocity
    np.testing.assert_allclose(kf.x[:, 2], a, atol=1e-2)  # acceleration


def _textbook_kalman(zs: np.ndarray, x0: float) -> np.ndarray:
    """Direct matrix form of the predict/update equations, one joint."""
    x = np.array([[x0], [0.0], [0.0]])
    p = np.eye(3)
    out = []
    for z in zs:
        x = F @ x
        p = F @ p @ F.T + QM
        if np.isfinite(z):
            s = H @ p @ H.T + R
            k = p @ H.T @ np.linalg.inv(s)
            x = x + k @ (np.array([[z]]) - H @ x)
            p = (np.eye(3) - k @ H) @ p
        out.append(x[0, 0])
    return np.array(out)


def test_kalman_matches_direct_matrix_equations() -> None:
    rng = np.random.default_rng(3)
    zs = np.cumsum(rng.normal(scale=0.05, size=(300, 4)), axis=0)
    zs[100:105, 2] = np.nan  # a dropped measurement coasts on the model
    x0 = np.array([0.0, 1.57, -0.2, 0.4])
    est = kalman_const_acc(zs, x0=x0)
    for j in range(4):
        np.testing.assert_allclose(est[:, j], _textbook_kalman(zs[:, j], x0[j]), atol=1e-10)


def test_kalman_steady_state_covariance_solves_the_riccati_equation() -> None:
    kf = KalmanConstAcc(3)
    for _ in range(3000):
        kf.step(np.zeros(3))
    prior = solve_discrete_are(F.T, H.T, QM, np.array([[R]]))  # steady predicted covariance
    gain = prior @ H.T / (H @ prior @ H.T + R)
    posterior = (np.eye(3) - gain @ H) @ prior
    for j in range(3):
        np.testing.assert_allclose(kf.P[j], posterior, rtol=1e-6, atol=1e-12)


def test_kalman_rejects_bad_input() -> None:
    with pytest.raises(InputError):
        KalmanConstAcc(0)
    with pytest.raises(InputError):
        KalmanConstAcc(2).step(np.zeros(3))
    with pytest.raises(InputError):
        KalmanConstAcc(2, r=0.0)


# --- one-euro -------------------------------------------------------------------------------


def test_one_euro_passes_a_constant_unchanged_on_irregular_timestamps() -> None:
    ts = np.cumsum(np.random.default_rng(0).uniform(0.01, 0.05, 200))
    x = np.tile([3.5, -2.0, 1e4], (200, 1))
    np.testing.assert_array_equal(one_euro(x, ts, min_cutoff=0.05, beta=80.0), x)


def test_one_euro_without_beta_is_the_exponential_low_pass_of_the_formula() -> None:
    """beta = 0: a fixed cut-off, so a unit step decays as Π (1 − α_i), α = 1 / (1 + τ / Δt)."""
    ts = np.cumsum(np.r_[0.0, np.random.default_rng(1).uniform(0.01, 0.04, 99)])
    x = np.r_[0.0, np.ones(99)]
    y = one_euro(x, ts, min_cutoff=2.0, beta=0.0)
    tau = 1 / (2 * np.pi * 2.0)
    alpha = 1 / (1 + tau / np.diff(ts))
    np.testing.assert_allclose(y[1:], 1 - np.cumprod(1 - alpha), rtol=1e-12)


def test_one_euro_step_converges_and_faster_with_beta() -> None:
    ts = np.arange(300) / 30.0
    x = np.r_[np.zeros(30), np.full(270, 10.0)]
    slow = one_euro(x, ts, min_cutoff=0.5, beta=0.0)
    fast = one_euro(x, ts, min_cutoff=0.5, beta=1.0)
    assert abs(slow[-1] - 10) < 0.01 and abs(fast[-1] - 10) < 0.01
    assert np.all(np.diff(slow[30:]) >= 0) and np.all(fast[30:] <= 10 + 1e-9)  # no overshoot
    assert np.all(fast[31:60] > slow[31:60])  # the jump's speed opens the filter


@pytest.mark.parametrize("speed", [1.0, 10.0, 100.0])
def test_one_euro_cutoff_grows_with_speed_as_the_formula_says(speed: float) -> None:
    """On a ramp the smoothed speed is the ramp's, so the cut-off settles at
    f_c = min_cutoff + beta · speed · scale and the lag behind the ramp at speed · τ."""
    min_cutoff, beta, scale = 0.1, 0.5, 0.2
    ts = np.arange(3000) / 100.0
    y = one_euro(speed * ts, ts, min_cutoff=min_cutoff, beta=beta, scale=scale)
    cutoff = min_cutoff + beta * speed * scale
    lag = speed / (2 * np.pi * cutoff)  # an exponential low-pass trails a ramp by speed · τ
    np.testing.assert_allclose(speed * ts[-1] - y[-1], lag, rtol=1e-6)


def test_one_euro_lags_less_on_faster_ramps() -> None:
    ts = np.arange(1000) / 60.0
    lags = [v * ts[-1] - one_euro(v * ts, ts, min_cutoff=0.05, beta=80.0)[-1] for v in (0.1, 1, 10)]
    assert lags[0] / 0.1 > lags[1] / 1 > lags[2] / 10  # relative lag shrinks with speed


def test_one_euro_follows_time_not_sample_count() -> None:
    """The same motion sampled at 30 and 60 fps gives nearly the same smoothed curve."""

    def run(fps: float) -> tuple[np.ndarray, np.ndarray]:
        ts = np.arange(int(3 * fps)) / fps
        x = np.where(ts >= 0.5, 1.0, 0.0) + 0.2 * np.sin(2 * np.pi * 0.7 * ts)
        return ts, one_euro(x, ts, min_cutoff=1.0, beta=0.5)

    t30, y30 = run(30.0)
    t60, y60 = run(60.0)
    assert np.max(np.abs(np.interp(t30, t60, y60) - y30)[t30 > 1.0]) < 0.02


def test_one_euro_nan_restarts_only_that_value_and_old_times_pass_through() -> None:
    f = OneEuro(min_cutoff=0.1, beta=0.0)
    f.step([0.0, 0.0], 0.0)
    out = f.step([np.nan, 1.0], 0.1)
    assert np.isnan(out[0]) and 0 < out[1] < 1
    out = f.step([5.0, 1.0], 0.2)
    assert out[0] == 5.0 and 0 < out[1] < 1  # a new start passes unchanged
    np.testing.assert_array_equal(f.step([7.0, 7.0], 0.2), [7.0, 7.0])  # not after the last
    f.reset()
    np.testing.assert_array_equal(f.step([9.0, -9.0], 0.3), [9.0, -9.0])


def test_one_euro_keeps_float32_and_rejects_bad_input() -> None:
    x = np.ones((5, 3), np.float32)
    assert one_euro(x, np.arange(5.0), min_cutoff=1, beta=0).dtype == np.float32
    with pytest.raises(InputError, match="strictly increasing"):
        one_euro(x, [0, 1, 1, 2, 3], min_cutoff=1, beta=0)
    with pytest.raises(InputError, match="min_cutoff"):
        OneEuro(min_cutoff=0.0, beta=1.0)
    with pytest.raises(InputError, match="beta"):
        OneEuro(min_cutoff=1.0, beta=-1.0)
