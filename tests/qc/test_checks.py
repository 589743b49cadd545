"""Verdicts: absolute thresholds, the dataset-relative outlier check, applying them to a folder."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError
from qc_data import synthetic_take, write_synthetic_dataset

from gesturebank.datasets import open as open_dataset
from gesturebank.qc.checks import QCConfig, absolute_reasons, robust_z, run_qc, verdicts
from gesturebank.qc.corrupt import corrupt, rederive

GOOD = {
    "duration_s": 5.0,
    "missing_keypoints_fraction": 0.0,
    "keypoint_gap_s": 0.0,
    "bone_cv_max": 0.05,
    "limit_frames_fraction": 0.1,
    "jitter_fraction": 0.02,
    "swap_events": 0.0,
    "spike_max": 0.1,
    "frozen_fraction": 0.0,
    "motion_range": 0.5,
    "jerk_raw": 1e6,
    "jerk": 1e4,
}


def test_a_good_take_passes_and_nan_fails_nothing() -> None:
    assert absolute_reasons(GOOD, QCConfig()) == []
    assert absolute_reasons(dict.fromkeys(GOOD, float("nan")), QCConfig()) == []


@pytest.mark.parametrize(
    ("key", "value", "text"),
    [
        ("duration_s", 0.5, "too short: 0.50 s < 1.00 s"),
        ("missing_keypoints_fraction", 0.4, "in 40% of frames (max 25%)"),
        ("keypoint_gap_s", 0.8, "keypoints lost for 0.80 s (max 0.50 s)"),
        ("bone_cv_max", 0.3, "3D bone length varies by 30% (max 25%)"),
        ("limit_frames_fraction", 0.7, "in 70% of frames (max 60%)"),
        ("jitter_fraction", 0.2, "jitter: 20% of raw motion power above 7 Hz (max 15%)"),
        ("swap_events", 2.0, "left/right arms swapped 2× (max 0)"),
        ("spike_max", 1.5, "keypoint jumps 1.50 shoulder widths"),
        ("frozen_fraction", 0.3, "frozen (exactly repeated) in 30% of frames"),
        ("motion_range", np.radians(1.0), "static: no joint moves more than 1.0° (min 2.0°)"),
    ],
)
def test_each_absolute_check_gives_its_reason_with_numbers(key, value, text) -> None:
    reasons = absolute_reasons({**GOOD, key: value}, QCConfig())
    assert len(reasons) == 1 and text in reasons[0]


def test_absolute_jerk_ceiling_is_optional() -> None:
    assert absolute_reasons({**GOOD, "jerk_raw": 1e12}, QCConfig()) == []
    reasons = absolute_reasons({**GOOD, "jerk_raw": 1e12}, QCConfig(max_jerk_raw=1e9))
    assert reasons == ["raw jerk 1e+12 rad²/s⁵ (max 1e+09)"]


def test_robust_z_against_formula() -> None:
    v = np.array([1.0, 2.0, 3.0, 4.0, 100.0])
    z, med = robust_z(v)
    mad = 1.4826 * np.median(np.abs(v - 3.0))  # median 3, deviations 2 1 0 1 97 → MAD 1
    assert med == 3.0
    np.testing.assert_allclose(z, (v - 3.0) / mad)


def test_one_failed_subject_stands_out_as_in_fig_4_7() -> None:
    rng = np.random.default_rng(0)
    takes = {f"s{i}": {**GOOD, "jerk_raw": 1e6 * rng.lognormal(0, 0.3)} for i in range(12)}
    takes["s12"] = {**GOOD, "jerk_raw": 3e7}
    result = verdicts(takes, QCConfig())
    assert {k for k, (s, _) in result.items() if s == "rejected"} == {"s12"}
    (reason,) = result["s12"][1]
    median = np.median([m["jerk_raw"] for m in takes.values()])
    assert reason.startswith(f"raw jerk {3e7 / median:.1f}× dataset median (robust z ")


def test_relative_check_needs_enough_takes_and_a_real_ratio() -> None:
    few = {"a": GOOD, "b": GOOD, "c": {**GOOD, "jerk_raw": 1e9}}
    assert all(s == "accepted" for s, _ in verdicts(few, QCConfig()).values())
    # near-identical takes: huge z but a tiny ratio must not reject
    tight = {f"t{i}": {**GOOD, "jerk_raw": 1e6 * (1 + 1e-6 * i)} for i in range(9)}
    tight["t9"] = {**GOOD, "jerk_raw": 1.5e6}
    assert all(s == "accepted" for s, _ in verdicts(tight, QCConfig()).values())


def test_config_validates() -> None:
    with pytest.raises(ValidationError):
        QCConfig(unknown=1)
    with pytest.raises(ValidationError):
        QCConfig(max_missing_fraction=2)


def test_run_qc_rewrites_records_and_manifest_and_keeps_rejected_takes(tmp_path) -> None:
    takes = {f"subj{i}_take": synthetic_take(seed=i) for i in range(6)}
    takes["bad_take"] = rederive(corrupt(takes["subj0_take"], "swap", 2, seed=1))
    out = write_synthetic_dataset(tmp_path, takes)
    result = run_qc(out)
    assert result["bad_take"][0] == "rejected"
    assert all(result[k][0] == "accepted" for k in takes if k != "bad_take")
    ds = open_dataset(out)
    rows = {r["take_id"]: r for r in ds.records()}
    assert len(rows) == 7  # the rejected take stays in the dataset, flagged
    assert rows["bad_take"]["qc_status"] == "rejected"
    assert any("left/right arms swapped" in r for r in rows["bad_take"]["qc_reasons"])
    assert rows["subj1_take"]["metrics"]["duration_s"] > 2  # measured, merged over the builder's
    assert "jerk_raw/HeadPitch" in rows["subj1_take"]["metrics"]
    assert ds.info["takes"] == {"accepted": 6, "rejected": 1, "failed": 0}
    assert ds.take_ids("accepted") == sorted(k for k in takes if k != "bad_take")
