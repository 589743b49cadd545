"""Each QC metric against its formula or a known value."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from gesturebank.clip import part_columns
from gesturebank.config import QCConfig
from gesturebank.filters import unwrap_angles
from gesturebank.qc import metrics as M
from gesturebank.robot import pepper
from gesturebank.skeletons import COCO17
from gesturebank.testing.clips import synthetic_clip
from gesturebank.testing.corrupt import rederive

IDX = COCO17.index


def test_jerk_of_a_cubic_is_known() -> None:
    # θ = c t³: Δ³θ = 6c / f³ every step, so Eq. 3.21 gives J = ½ f⁵ (6c / f³)² = 18 c² / f.
    f, c = 50.0, 0.7
    t = np.arange(200) / f
    j = M.jerkiness_per_joint(c * t[:, None] ** 3, f)
    assert j[0] == pytest.approx(18 * c**2 / f, rel=1e-9)


@pytest.mark.parametrize("poly", [lambda t: 0 * t + 1.3, lambda t: 2 * t - 1, lambda t: t**2])
def test_jerk_of_constant_linear_quadratic_is_zero(poly) -> None:
    t = np.arange(100) / 30.0
    assert M.jerkiness_per_joint(poly(t)[:, None], 30.0)[0] == pytest.approx(0.0, abs=1e-6)


def test_jerk_matches_eq_3_21_literally() -> None:
    rng = np.random.default_rng(1)
    theta, f = rng.normal(size=(40, 11)), 25.0
    n = len(theta)
    expect = np.zeros(11)
    for i in range(n - 3):  # J = 1 / (2 f (N − 3)) Σ_i (Δ³θ_i f³)²
        d3 = (theta[i + 3] - 3 * theta[i + 2] + 3 * theta[i + 1] - theta[i]) * f**3
        expect += d3**2
    expect /= 2 * f * (n - 3)
    np.testing.assert_allclose(M.jerkiness_per_joint(theta, f), expect, rtol=1e-12)


def test_jerk_skips_windows_touching_nan() -> None:
    f, c = 30.0, 1.0
    t = np.arange(60) / f
    theta = c * t[:, None] ** 3
    theta[20] = np.nan
    assert M.jerkiness_per_joint(theta, f)[0] == pytest.approx(18 * c**2 / f)
    assert np.isnan(M.jerkiness_per_joint(np.full((10, 1), np.nan), f)[0])


def test_uniform_resampling_makes_frame_rates_comparable() -> None:
    # A cubic filmed at 60 fps, resampled to 30 Hz, has the 30 Hz value 18 c² / 30.
    t60 = np.arange(120) / 60.0
    theta = (0.5 * t60**3)[:, None]
    j = M.jerkiness_per_joint(M.uniform(theta, t60, rate_hz=30.0, max_gap_s=0.25), 30.0)[0]
    assert j == pytest.approx(18 * 0.25 / 30.0, rel=1e-6)


def test_longest_gap() -> None:
    bad = np.zeros(30, bool)
    bad[[5, 6, 7, 20]] = True
    t = np.arange(30) / 30.0
    assert M.longest_run_s(bad, t) == pytest.approx(3 / 30)
    end = np.zeros(30, bool)
    end[-2:] = True
    assert M.longest_run_s(end, t) == pytest.approx(2 / 30)
    assert M.longest_run_s(np.zeros(30, bool), t) == 0.0


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def test_bone_cv_of_rigid_motion_is_zero_and_of_a_stretch_is_known() -> None:
    rng = np.random.default_rng(2)
    body = pepper.fk_coco17(pepper.neutral_pose()[None])[0]
    frames = np.stack([body @ _random_rotation(rng).T + rng.normal(size=3) for _ in range(50)])
    np.testing.assert_allclose(M.bone_cv(frames), 0.0, atol=1e-9)
    stretched = frames.copy()
    # forearm alternately 1.1× and 0.9× as long: CV = 0.1 exactly
    k = np.where(np.arange(50) % 2, 1.1, 0.9)[:, None]
    e, w = IDX["left_elbow"], IDX["left_wrist"]
    stretched[:, w] = frames[:, e] + k * (frames[:, w] - frames[:, e])
    cv = M.bone_cv(stretched)
    assert cv[M.UPPER_BONES.index(("left_elbow", "left_wrist"))] == pytest.approx(0.1)


def _walking_skeleton(n: int = 60) -> np.ndarray:
    """A skeleton whose arms move smoothly (shoulder width 0.4)."""
    body = pepper.fk_coco17(pepper.neutral_pose()[None])[0]
    t = np.arange(n) / 30.0
    frames = np.repeat(body[None], n, axis=0)
    for name in ("left_elbow", "left_wrist", "right_elbow", "right_wrist"):
        frames[:, IDX[name], 0] += 0.1 * np.sin(2 * np.pi * 0.7 * t + 0.3)
    return frames


def test_swap_detection_on_a_constructed_swap() -> None:
    frames = _walking_skeleton()
    assert M.swap_events(frames) == 0
    swapped = frames.copy()
    for a, b in (("left_elbow", "right_elbow"), ("left_wrist", "right_wrist")):
        swapped[20:30, [IDX[a], IDX[b]]] = frames[20:30, [IDX[b], IDX[a]]]
    assert M.swap_events(swapped) == 2  # in and back out
    assert M.swap_events(swapped[:, :, :2]) == 2  # in 2D too


def test_frozen_fraction() -> None:
    frames = _walking_skeleton()
    assert M.frozen_fraction(frames) == 0.0
    frames[10:25] = frames[10]
    assert M.frozen_fraction(frames) == pytest.approx(14 / 59)


def test_spike_size_in_shoulder_widths() -> None:
    frames = _walking_skeleton()
    width = np.linalg.norm(frames[0, IDX["left_shoulder"]] - frames[0, IDX["right_shoulder"]])
    assert np.nanmax(M.spike_sizes(frames)) < 0.05
    frames[30, IDX["right_wrist"], 1] += 1.5 * width
    assert np.nanmax(M.spike_sizes(frames)) == pytest.approx(1.5, rel=0.02)


def test_limit_frames() -> None:
    prof = pepper.load_profile()
    a = np.tile((prof.lower + prof.upper) / 2, (4, 1))
    a[1, 0] = prof.upper[0]
    a[2, 3] = prof.lower[3]
    at = M.limit_frames(a, prof.lower, upper=prof.upper)
    assert at.any(axis=1).tolist() == [False, True, True, False]


def test_a_limb_held_still_past_the_limit_is_not_frozen() -> None:
    """Issue 41: the robot held at a limit for 10 s while the person folds the elbow 0.4 rad
    past it in half a second and then keeps it still (test.bvh 225-237 s) is frozen only while
    the fold lasts; waving 0.3 rad past the limit for 4 s is frozen for those 4 s."""
    rate = 100.0
    t = np.arange(1200) / rate
    held = np.zeros((len(t), 2), bool)
    held[100:1100, 0] = True  # 1-11 s
    held[100:500, 1] = True  # 1-5 s
    fold = 1.6 + np.clip((t - 1.0) / 0.5, 0, 1) * 0.4 + 0.005 * np.sin(7 * t)
    wave = 1.7 + 0.3 * np.sin(2 * np.pi * t)
    person = np.stack([fold, wave], axis=1)
    frozen = M.frozen_frames(held, person, rate_hz=rate, min_motion=0.2, window_s=1.0)
    spans = M.frozen_spans_s(frozen, rate_hz=rate)
    assert spans[0] < 1.0  # the fold itself, not the hold
    assert spans[1] == pytest.approx(4.0, abs=0.02)
    qc = QCConfig()
    assert spans[0] < qc.max_frozen_at_limit_s < spans[1]


def test_high_frequency_share() -> None:
    t = np.arange(600) / 30.0
    slow = np.sin(2 * np.pi * 1.0 * t)[:, None]
    fast = np.sin(2 * np.pi * 11.0 * t)[:, None]
    assert M.high_freq_fraction(slow, rate_hz=30.0, above_hz=7.0) < 0.01
    assert M.high_freq_fraction(fast, rate_hz=30.0, above_hz=7.0) > 0.99
    mixed = np.hstack([slow, fast])  # equal power in each column → half above 7 Hz
    assert M.high_freq_fraction(mixed, rate_hz=30.0, above_hz=7.0) == pytest.approx(0.5, abs=0.01)
    assert np.isnan(
        M.high_freq_fraction(slow, rate_hz=12.0, above_hz=7.0)
    )  # the clock cannot show 7 Hz


def test_a_step_across_pi_is_no_jitter() -> None:
    """An ElbowYaw swinging at 2 Hz just short of ±π (beyond the robot's range) crosses it for a
    few frames each swing: wrapped, those are 2π steps (12 % of the power above 7 Hz);
    unwrapped, the swing is a sine. Unknown samples stay unknown."""
    t = np.arange(300) / 30.0
    swing = np.angle(np.exp(1j * (np.pi - 0.25 + 0.3 * np.sin(2 * np.pi * 2.0 * t))))[:, None]
    assert M.high_freq_fraction(swing, rate_hz=30.0, above_hz=7.0) > 0.1
    assert M.high_freq_fraction(unwrap_angles(swing), rate_hz=30.0, above_hz=7.0) < 1e-6
    swing[10] = np.nan
    unwrapped = unwrap_angles(swing)
    assert np.isnan(unwrapped[10, 0]) and np.nanmax(np.abs(np.diff(unwrapped[:, 0]))) < 0.2


def test_motion_range() -> None:
    assert M.motion_range(np.zeros((50, 11))) == 0.0
    ramp = np.zeros((101, 11))
    ramp[:, 4] = np.linspace(0, 1, 101)
    assert M.motion_range(ramp) == pytest.approx(0.9)


def test_clip_metrics_of_a_clean_synthetic_clip(clip) -> None:
    m = M.clip_metrics(clip, profile=pepper.load_profile(), qc=QCConfig())
    assert m.duration_s == pytest.approx(len(clip.times) / 100)
    assert m.jerk == pytest.approx(sum(m.jerk_per_joint))
    assert m.jerk_raw > m.jerk > 0  # the low-pass removes jerk
    assert m.head_unknown_fraction == 0 and m.arms_unknown_fraction == 0
    assert m.torso_gap_s == 0
    assert m.swap_events == 0 and m.frozen_fraction == 0
    assert m.spike_max < 0.1 and m.jitter_fraction < 0.01
    assert m.motion_range > 0.2
    assert m.facing_away_fraction == 0 and m.sideways_fraction == 0
    assert m.people == 1.0
    assert all(isinstance(v, float) for v in m.to_dict().values())


def test_an_unseen_arm_is_masked_not_measured(clip) -> None:
    """An occluded arm leaves the other metrics clean: its keypoints are not seen (`valid`)."""
    valid = clip.valid.copy()
    valid[:, [IDX["left_elbow"], IDX["left_wrist"]]] = False
    joints = clip.pose3d.joints.copy()
    joints[:, IDX["left_wrist"]] += np.random.default_rng(0).normal(0, 0.3, joints[:, 0].shape)
    hidden = rederive(replace(clip, valid=valid, pose3d=replace(clip.pose3d, joints=joints)))
    m = M.clip_metrics(hidden, profile=pepper.load_profile(), qc=QCConfig())
    left = [pepper.INDEX[j] for j in ("LShoulderRoll", "LShoulderPitch", "LElbowRoll", "LElbowYaw")]
    assert not hidden.mask[:, left].any() and hidden.mask[:, pepper.INDEX["RElbowRoll"]].all()
    assert m.arms_unknown_fraction == 0  # the other arm is known
    assert m.spike_max < 0.1 and m.bone_cv_max < 0.05  # the noisy wrist is not judged


def test_the_raw_angles_of_a_part_masked_whole_are_not_judged(clip) -> None:
    """Issue 32: a head-and-shoulders clip glimpses an arm now and then (a hand rising into the
    frame); its arms are masked whole, and those glimpses of raw angles are no jitter or jerk of
    the clip. The same glimpses in a clip that keeps its arms are judged."""
    arms = part_columns("left_arm") + part_columns("right_arm")
    rng = np.random.default_rng(0)
    raw = clip.raw_angles.copy()
    glimpses = (np.arange(len(raw)) // 10) % 6 == 0  # runs of 10 frames, 1/6 of the clip
    raw[:, arms] = np.where(glimpses[:, None], rng.normal(0, 0.5, (len(raw), len(arms))), np.nan)
    mask = clip.mask.copy()
    mask[:, arms] = False
    angles, angles01 = clip.angles.copy(), clip.angles01.copy()
    angles[:, arms] = angles01[:, arms] = np.nan
    head_only = replace(clip, raw_angles=raw, mask=mask, angles=angles, angles01=angles01)
    qc, profile = QCConfig(), pepper.load_profile()
    m = M.clip_metrics(head_only, profile=profile, qc=qc)
    assert m.left_arm_unknown_fraction == m.right_arm_unknown_fraction == 1.0
    assert m.jitter_fraction < 0.01
    assert all(np.isnan(m.jerk_raw_per_joint[j]) for j in arms)
    kept = M.clip_metrics(replace(clip, raw_angles=raw), profile=profile, qc=qc)
    assert kept.jitter_fraction > 0.05 and kept.jerk_raw > 100 * m.jerk_raw
    assert all(np.isfinite(kept.jerk_raw_per_joint[j]) for j in arms)


def test_facing_away_and_sideways(clip) -> None:
    m = M.clip_metrics(mirror_image_only(clip), profile=pepper.load_profile(), qc=QCConfig())
    assert m.facing_away_fraction == 1.0
    xy = clip.pose2d.keypoints.copy()
    xy[:, IDX["nose"], 0] = xy[:, IDX["left_shoulder"], 0] + 50  # nose beyond a shoulder
    side = replace(clip, pose2d=replace(clip.pose2d, keypoints=xy))
    m = M.clip_metrics(side, profile=pepper.load_profile(), qc=QCConfig())
    assert m.sideways_fraction == 1.0


def mirror_image_only(clip):
    """The 2D view flipped left/right without exchanging the labels: seen from behind."""
    kp = clip.pose2d.keypoints.copy()
    kp[..., 0] = clip.pose2d.image_size[0] - kp[..., 0]
    return replace(clip, pose2d=replace(clip.pose2d, keypoints=kp))


def test_the_same_motion_at_30_and_60_fps_measures_alike() -> None:
    """Frame-rate independence of every threshold-bearing metric."""
    a = synthetic_clip(seconds=6.0, fps=30.0, seed=4)
    b = synthetic_clip(seconds=6.0, fps=60.0, seed=4)
    qc, prof = QCConfig(), pepper.load_profile()
    ma, mb = M.clip_metrics(a, profile=prof, qc=qc), M.clip_metrics(b, profile=prof, qc=qc)
    for key in ("jerk_raw", "jitter_fraction", "motion_range", "shoulder_width", "spike_max"):
        assert ma.value(key) == pytest.approx(mb.value(key), rel=0.05, abs=0.01), key
