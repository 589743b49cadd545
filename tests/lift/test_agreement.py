"""The agreement statistics of benchmarks/fidelity.py against a textbook table and formulas."""

from __future__ import annotations

import statistics

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gesturebank.lift.agreement import (
    Z_95,
    agreement,
    bias,
    bootstrap_over_clips,
    icc_2_1,
    icc_agreement,
    limits_of_agreement,
)

# Shrout & Fleiss (1979), Table 2: six targets rated by four judges. Their Table 4 gives
# ICC(1,1) = .17, ICC(2,1) = .29, ICC(3,1) = .71 for these ratings.
SHROUT_FLEISS = np.array(
    [[9, 2, 5, 8], [6, 1, 3, 2], [8, 4, 6, 8], [7, 1, 2, 6], [10, 5, 6, 9], [6, 2, 4, 7]], float
)


def test_icc_2_1_matches_shrout_and_fleiss_table() -> None:
    assert icc_2_1(SHROUT_FLEISS) == pytest.approx(0.29, abs=0.005)


def test_icc_2_1_leaves_out_targets_with_a_missing_rating() -> None:
    with_gap = np.vstack([SHROUT_FLEISS, [np.nan, 1, 2, 3]])
    assert icc_2_1(with_gap) == pytest.approx(icc_2_1(SHROUT_FLEISS))


def test_icc_is_one_for_a_perfect_instrument_and_falls_with_an_offset() -> None:
    truth = np.sin(np.linspace(0, 6, 200))
    assert icc_agreement(measured=truth, truth=truth) == pytest.approx(1.0)
    # absolute agreement: an offset c is disagreement (unlike a consistency ICC); for many
    # targets of variance v the ICC tends to v / (v + c² / 2)
    v = truth.var(ddof=1)
    got = icc_agreement(measured=truth + 1.0, truth=truth)
    assert got == pytest.approx(v / (v + 0.5), rel=0.01)


finite = st.floats(-100, 100, allow_nan=False, allow_infinity=False)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(finite, finite), min_size=3, max_size=40))
def test_limits_of_agreement_follow_bland_altmans_formula(pairs: list[tuple[float, float]]) -> None:
    measured, truth = (np.array(v) for v in zip(*pairs, strict=True))
    got = limits_of_agreement(measured=measured, truth=truth)
    d = [m - t for m, t in pairs]
    mean, sd = statistics.fmean(d), statistics.stdev(d)
    assert got.bias == pytest.approx(mean, abs=1e-9)
    assert got.lower == pytest.approx(mean - 1.96 * sd, abs=1e-6 + 1e-3 * sd)
    assert got.upper == pytest.approx(mean + Z_95 * sd, abs=1e-9 + 1e-9 * sd)


def test_limits_of_agreement_skip_unknown_readings() -> None:
    got = limits_of_agreement(measured=np.array([1.0, np.nan, 3.0]), truth=np.array([0.0, 5, 1]))
    assert (got.bias, got.upper - got.bias) == pytest.approx((1.5, Z_95 * np.sqrt(0.5)))


def test_bootstrap_resamples_clips_not_frames() -> None:
    # two clips, each many frames off by a constant: +1 and −1. Resampling frames would give a
    # narrow interval around 0; clips are the independent units, so the interval spans ±1.
    clips = [(np.full(500, 1.0), np.zeros(500)), (np.full(500, -1.0), np.zeros(500))]
    got = bootstrap_over_clips(clips, bias, draws=400, seed=1)
    assert got.value == pytest.approx(0.0)
    assert got.low == pytest.approx(-1.0) and got.high == pytest.approx(1.0)


def test_one_clip_has_no_interval() -> None:
    got = bootstrap_over_clips([(np.arange(10.0), np.zeros(10))], bias)
    assert got.value == pytest.approx(4.5) and np.isnan(got.low) and np.isnan(got.high)


def test_agreement_intervals_hold_the_pooled_value() -> None:
    rng = np.random.default_rng(0)
    clips = []
    for _ in range(8):
        truth = rng.normal(size=60)
        clips.append((truth + 0.3 + rng.normal(scale=0.2, size=60), truth))
    got = agreement(clips, draws=300)
    assert got.clips == 8 and got.readings == 480
    for interval in (got.bias, got.lower, got.upper, got.icc, got.mae):
        assert interval.low <= interval.value <= interval.high
    assert 0.2 < got.bias.value < 0.4 and 0.8 < got.icc.value < 1.0
