"""The corruption toolkit: each kind does what it says, seeded, and the QC sees it."""

from __future__ import annotations

import numpy as np
import pytest

from gesturebank.config import QCConfig
from gesturebank.qc import metrics as M
from gesturebank.qc.clip_metrics import ClipMetrics
from gesturebank.robot import pepper
from gesturebank.testing.corrupt import KINDS, corrupt, mirror, rederive, window


def measure(clip) -> ClipMetrics:
    return M.clip_metrics(clip, profile=pepper.load_profile(), qc=QCConfig())


@pytest.mark.parametrize("kind", KINDS)
def test_seeded_and_pure(clip, kind) -> None:
    before = clip.to_arrays()
    a = corrupt(clip, kind, strength=2 if kind == "swap" else 0.5, seed=3).to_arrays()
    b = corrupt(clip, kind, strength=2 if kind == "swap" else 0.5, seed=3).to_arrays()
    for k, v in clip.to_arrays().items():
        np.testing.assert_array_equal(v, before[k])  # input untouched
        np.testing.assert_array_equal(a[k], b[k])
    assert not np.array_equal(a["pose3d_joints"], before["pose3d_joints"], equal_nan=True)


def test_unknown_kind(clip) -> None:
    with pytest.raises(ValueError, match="unknown corruption"):
        corrupt(clip, "melt", strength=1.0)


def test_each_kind_is_measured(clip) -> None:
    clean = measure(clip)
    m = {
        kind: measure(rederive(corrupt(clip, kind, strength=s, seed=1)))
        for kind, s in (
            ("spikes", 2.0),
            ("jitter", 0.1),
            ("frozen", 0.3),
            ("dropout", 0.3),
            ("swap", 1),
        )
    }
    assert m["spikes"].spike_max == pytest.approx(2.0, rel=0.1)
    assert m["jitter"].jitter_fraction > 10 * clean.jitter_fraction + 0.05
    assert m["frozen"].frozen_fraction == pytest.approx(0.3, abs=0.02)
    # a dropout is unseen everywhere: head and both arms unknown for its share of the clip
    assert m["dropout"].head_unknown_fraction == pytest.approx(0.3, abs=0.03)
    assert m["dropout"].arms_unknown_fraction == pytest.approx(0.3, abs=0.03)
    assert m["dropout"].torso_gap_s == pytest.approx(0.3 * 3.0, abs=0.05)
    assert m["swap"].swap_events >= 1
    assert m["swap"].jerk_raw > 3 * clean.jerk_raw


def test_raw_angle_target(clip) -> None:
    bad = corrupt(clip, "jitter", strength=0.05, seed=0, target="raw_angles")
    np.testing.assert_array_equal(bad.pose3d.joints, clip.pose3d.joints)
    assert np.std(bad.raw_angles - clip.raw_angles) == pytest.approx(0.05, rel=0.1)
    again = rederive(bad, from_pose=False)
    assert measure(again).jerk_raw > 10 * measure(clip).jerk_raw


def test_mirror_twice_is_identity_and_mirrors_the_arms(clip) -> None:
    twice = mirror(mirror(clip))
    np.testing.assert_allclose(twice.pose2d.keypoints, clip.pose2d.keypoints, atol=1e-4)
    np.testing.assert_allclose(twice.pose3d.joints, clip.pose3d.joints, atol=1e-4)
    once = rederive(mirror(clip))
    # the left arm's roll becomes minus the right arm's roll (Pepper's sign convention)
    np.testing.assert_allclose(once.raw_angles[:, 2], -clip.raw_angles[:, 6], atol=1e-3)
    assert measure(once).facing_away_fraction == 0  # a mirrored person still faces us


def test_window_slices_both_clocks(clip) -> None:
    part = window(clip, 1.0, t1=2.0)
    assert part.times[0] >= 1.0 and part.times[-1] < 2.0
    assert part.timestamps[0] >= 1.0 and part.timestamps[-1] < 2.0
    assert len(part.pose3d) == len(part.timestamps) == len(part.raw_angles) == len(part.valid)
    assert len(part.angles) == len(part.times) == len(part.mask) == 100


def test_rederive_reproduces_the_builder_on_a_real_clip(real_dataset) -> None:
    from gesturebank.datasets import open as open_dataset

    ds = open_dataset(real_dataset)
    _, clip = next(iter(ds))
    again = rederive(clip, profile=ds.info.robot_profile)
    np.testing.assert_allclose(again.raw_angles, clip.raw_angles, atol=1e-5, equal_nan=True)
    np.testing.assert_allclose(again.angles, clip.angles, atol=1e-4, equal_nan=True)
    np.testing.assert_array_equal(again.mask, clip.mask)
