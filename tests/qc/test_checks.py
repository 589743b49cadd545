"""Verdicts: absolute thresholds, the dataset-relative outlier check, re-judging a folder."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from pydantic import ValidationError

from gesturebank.clip import Clip
from gesturebank.config import Config
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.refresh import refresh
from gesturebank.qc.checks import NO_PART, QCConfig, absolute_reasons, robust_z, verdicts
from gesturebank.qc.clip_metrics import ClipMetrics
from gesturebank.qc.metrics import clip_metrics
from gesturebank.robot import pepper
from gesturebank.testing.clips import synthetic_clip, write_dataset
from gesturebank.testing.corrupt import corrupt, rederive

GOOD = {
    "duration_s": 5.0,
    "head_unknown_fraction": 0.0,
    "arms_unknown_fraction": 0.1,
    "bone_cv_max": 0.05,
    "out_of_reach_fraction": 0.7,
    "frozen_at_limit_s": 0.5,
    "jitter_fraction": 0.02,
    "swap_events": 0.0,
    "spike_max": 0.1,
    "frozen_fraction": 0.0,
    "motion_range": 0.5,
    "jerk_raw": 1e6,
    "jerk": 1e4,
    "facing_away_fraction": 0.0,
    "sideways_fraction": 0.1,
    "shoulder_width": 0.1,
    "image_change": 2.0,
    "people": 1.5,
    "speech_fraction": 0.8,
    "depth_confidence": 0.6,
    "expected_hand_error_cm": 8.0,
}


typed = ClipMetrics.from_dict


def _typed(metrics_by_clip: dict[str, dict[str, float]]) -> dict[str, ClipMetrics]:
    return {k: typed(m) for k, m in metrics_by_clip.items()}


def test_a_good_take_passes_and_nan_fails_nothing() -> None:
    assert absolute_reasons(typed(GOOD), QCConfig()) == []
    assert absolute_reasons(typed(dict.fromkeys(GOOD, float("nan"))), QCConfig()) == []


def test_parts_are_judged_alone_and_a_clip_needs_one() -> None:
    """Issue 32: a head-only clip (arms masked whole) passes; with no part left it is rejected,
    and the old whole-clip rule is opt-in."""
    head_only = {**GOOD, "arms_unknown_fraction": 1.0}
    head_only |= {"left_arm_unknown_fraction": 1.0, "right_arm_unknown_fraction": 1.0}
    assert absolute_reasons(typed(head_only), QCConfig()) == []
    nothing = {**head_only, "head_unknown_fraction": 1.0}
    assert absolute_reasons(typed(nothing), QCConfig()) == [NO_PART]
    old = QCConfig(max_arms_unknown_fraction=0.5)
    assert absolute_reasons(typed(head_only), old) == [
        "both arms unseen in 100% of the clip (max 50%)"
    ]


@pytest.mark.parametrize(
    ("key", "value", "text"),
    [
        ("head_unknown_fraction", 0.6, "head unseen in 60% of the clip (max 50%)"),
        ("arms_unknown_fraction", 0.7, "both arms unseen in 70% of the clip (max 50%)"),
        ("bone_cv_max", 0.3, "3D bone length varies by 30% (max 25%)"),
        ("frozen_at_limit_s", 2.5, "held within 0.02 rad of its limit for 2.5 s"),
        ("jitter_fraction", 0.2, "jitter: 20% of raw motion power above 7 Hz (max 15%)"),
        ("swap_events", 2.0, "left/right arms swapped 2× (max 0)"),
        ("spike_max", 1.5, "keypoint jumps 1.50 shoulder widths"),
        ("frozen_fraction", 0.3, "frozen (exactly repeated) in 30% of frames"),
        ("motion_range", np.radians(1.0), "static: no joint moves more than 1.0° (min 2.0°)"),
        ("facing_away_fraction", 0.8, "facing away in 80% of frames (max 70%)"),
        ("sideways_fraction", 0.6, "seen from the side in 60% of frames (max 50%)"),
        ("shoulder_width", 0.02, "too small: shoulders 2.0% of the frame height (min 3.0%)"),
        ("image_change", 0.01, "still picture: image change 0.010 (min 0.05)"),
        ("people", 6.0, "too many people: 6.0 on average (max 5)"),
        ("speech_fraction", 0.1, "no speech: speech heard in 10% of the clip (min 25%)"),
        ("expected_hand_error_cm", 13.0, "depth uncertain: expected hand error 13.0 cm"),
    ],
)
def test_each_absolute_check_gives_its_reason_with_numbers(key, value, text) -> None:
    whole = QCConfig(max_head_unknown_fraction=0.5, max_arms_unknown_fraction=0.5)  # opt-in
    reasons = absolute_reasons(typed({**GOOD, key: value}), whole)
    assert len(reasons) == 1 and text in reasons[0]


def test_reach_is_reported_not_judged_unless_the_old_rule_is_asked_for() -> None:
    """70 % of the frames beyond reach is no reason by default; qc.max_limit_fraction brings
    the old rule back as a filter."""
    assert absolute_reasons(typed(GOOD), QCConfig()) == []
    reasons = absolute_reasons(typed(GOOD), QCConfig(max_limit_fraction=0.6))
    assert reasons == ["a joint beyond the robot's reach in 70% of frames (max 60%)"]


def test_a_frozen_robot_names_the_joint() -> None:
    metrics = {**GOOD, "frozen_at_limit_s": 3.0, "frozen_at_limit_s/RElbowRoll": 3.0}
    (reason,) = absolute_reasons(typed(metrics), QCConfig())
    assert reason.startswith("robot frozen at a limit: RElbowRoll held") and "3.0 s" in reason
    assert absolute_reasons(typed(metrics), QCConfig(max_frozen_at_limit_s=None)) == []


def test_absolute_jerk_ceiling_is_optional() -> None:
    assert absolute_reasons(typed({**GOOD, "jerk_raw": 1e12}), QCConfig()) == []
    reasons = absolute_reasons(typed({**GOOD, "jerk_raw": 1e12}), QCConfig(max_jerk_raw=1e9))
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
    result = verdicts(_typed(takes), QCConfig())
    assert {k for k, (s, _) in result.items() if s == "rejected"} == {"s12"}
    (reason,) = result["s12"][1]
    median = np.median([m["jerk_raw"] for m in takes.values()])
    assert reason.startswith(f"raw jerk {3e7 / median:.1f}× dataset median (robust z ")


def test_relative_check_needs_enough_takes_and_a_real_ratio() -> None:
    few = {"a": GOOD, "b": GOOD, "c": {**GOOD, "jerk_raw": 1e9}}
    assert all(s == "accepted" for s, _ in verdicts(_typed(few), QCConfig()).values())
    # near-identical takes: huge z but a tiny ratio must not reject
    tight = {f"t{i}": {**GOOD, "jerk_raw": 1e6 * (1 + 1e-6 * i)} for i in range(9)}
    tight["t9"] = {**GOOD, "jerk_raw": 1.5e6}
    assert all(s == "accepted" for s, _ in verdicts(_typed(tight), QCConfig()).values())


def test_config_validates() -> None:
    with pytest.raises(ValidationError):
        QCConfig(unknown=1)
    with pytest.raises(ValidationError):
        QCConfig(max_arms_unknown_fraction=2)


def test_refresh_rejudges_every_clip_and_keeps_rejected_ones(tmp_path) -> None:
    clips = {
        f"subj{i}_take": [synthetic_clip(seed=i, clip_id=f"subj{i}_take__c000")] for i in range(6)
    }
    bad = rederive(
        corrupt(synthetic_clip(seed=0, clip_id="bad_take__c000"), "swap", strength=2, seed=1)
    )
    # judged whole (qc.stretch_rounds = 0): a clip cut around a failing stretch (issue 41) is
    # re-admitted by rebuilding, not by loosening (test_stretches_cut_when_rejudging)
    whole = Config.model_validate({"qc": {"stretch_rounds": 0}})
    out = write_dataset(tmp_path, {**clips, "bad_take": [bad]}, config=whole)
    ds = open_dataset(out)
    rows = {r.clip.clip_id: r for r in ds.clips(None)}
    assert len(rows) == 7  # the rejected clip stays in the dataset, flagged
    assert rows["bad_take__c000"].clip.qc_status == "rejected"
    assert any("left/right arms swapped" in r for r in rows["bad_take__c000"].clip.qc_reasons)
    assert "jerk_raw/HeadPitch" in rows["subj1_take__c000"].clip.metrics
    assert ds.info.clip_counts == {"accepted": 6, "rejected": 1, "failed": 0}
    assert ds.info.takes["bad_take"].usable_s == 0 and ds.info.takes["subj1_take"].accepted == 1
    # looser thresholds re-admit it without rebuilding, and are saved in dataset.json
    loose = Config.model_validate(
        {
            "qc": {
                "max_swap_events": 10,
                "max_jitter_fraction": 1.0,
                "max_bone_cv": 1.0,
                "outlier_z": 1e9,
                "stretch_rounds": 0,
            }
        }
    )
    refresh(out, loose)
    ds = open_dataset(out)
    assert ds.clip_ids("accepted") == sorted(rows)
    assert ds.info.config.qc.max_swap_events == 10


def _lifted(confidence: float) -> Clip:
    """A clip lifted by `blazepose-world` (calibrated) whose every frame has `confidence`."""
    c = synthetic_clip(seconds=2.0)
    pose3d = replace(c.pose3d, meta={"lifter": "blazepose-world"})
    return replace(
        c, pose3d=pose3d, depth_confidence=np.full(len(c.timestamps), confidence, np.float32)
    )


def test_a_clip_whose_depth_is_in_doubt_is_rejected_and_a_certain_one_is_not() -> None:
    """The limit on the expected hand error, end to end from the clip's per-frame confidence:
    arms along the camera's ray (confidence 0.05: the calibration's worst bin, 13.9 cm) fail the
    default 12.5 cm; arms in the image plane (0.95: 6.9 cm) pass; no limit, nothing fails."""
    profile = pepper.load_profile()
    doubtful = clip_metrics(_lifted(0.05), profile=profile, qc=QCConfig())
    assert doubtful.depth_confidence == pytest.approx(0.05)
    assert doubtful.expected_hand_error_cm == pytest.approx(13.9, abs=0.1)
    (reason,) = [r for r in absolute_reasons(doubtful, QCConfig()) if "depth" in r]
    assert reason == (
        "depth uncertain: expected hand error 13.9 cm (depth confidence 0.05; max 12.5 cm)"
    )
    certain = clip_metrics(_lifted(0.95), profile=profile, qc=QCConfig())
    assert certain.expected_hand_error_cm == pytest.approx(6.9, abs=0.1)
    assert not [r for r in absolute_reasons(certain, QCConfig()) if "depth" in r]
    off = QCConfig(max_expected_hand_error_cm=None)
    assert not [r for r in absolute_reasons(doubtful, off) if "depth" in r]


def test_motion_capture_and_uncalibrated_lifters_expect_no_or_unknown_error() -> None:
    profile = pepper.load_profile()
    c = _lifted(0.05)
    mocap = replace(c, pose3d=replace(c.pose3d, meta={"source": "bvh"}))
    assert clip_metrics(mocap, profile=profile, qc=QCConfig()).expected_hand_error_cm == 0.0
    other = replace(c, pose3d=replace(c.pose3d, meta={"lifter": "my-plugin"}))
    metrics = clip_metrics(other, profile=profile, qc=QCConfig())
    assert np.isnan(metrics.expected_hand_error_cm)
    assert not [r for r in absolute_reasons(metrics, QCConfig()) if "depth" in r]
