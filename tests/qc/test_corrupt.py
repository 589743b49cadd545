"""The corruption toolkit: each kind does what it says, seeded, and the QC sees it."""

from __future__ import annotations

import numpy as np
import pytest

from gesturebank.qc import metrics as M
from gesturebank.qc.corrupt import KINDS, corrupt, mirror, rederive, window


@pytest.mark.parametrize("kind", KINDS)
def test_seeded_and_pure(take, kind) -> None:
    before = {k: v.copy() for k, v in take.items()}
    a = corrupt(take, kind, 2 if kind == "swap" else 0.5, seed=3)
    b = corrupt(take, kind, 2 if kind == "swap" else 0.5, seed=3)
    for k in take:
        np.testing.assert_array_equal(take[k], before[k])  # input untouched
        np.testing.assert_array_equal(a[k], b[k])
    assert not np.array_equal(a["pose3d_joints"], take["pose3d_joints"], equal_nan=True)


def test_unknown_kind() -> None:
    with pytest.raises(ValueError, match="unknown corruption"):
        corrupt({}, "melt", 1.0)


def test_each_kind_is_measured(take) -> None:
    clean = M.take_metrics(take)
    m = {
        kind: M.take_metrics(rederive(corrupt(take, kind, s, seed=1)))
        for kind, s in (
            ("spikes", 2.0),
            ("jitter", 0.1),
            ("frozen", 0.3),
            ("dropout", 0.3),
            ("swap", 1),
        )
    }
    assert m["spikes"]["spike_max"] == pytest.approx(2.0, rel=0.1)
    assert m["jitter"]["jitter_fraction"] > 10 * clean["jitter_fraction"] + 0.05
    assert m["frozen"]["frozen_fraction"] == pytest.approx(0.3, abs=0.02)
    assert m["dropout"]["missing_keypoints_fraction"] == pytest.approx(0.3, abs=0.02)
    assert m["dropout"]["keypoint_gap_s"] == pytest.approx(0.3 * 3.0, abs=0.05)
    assert m["swap"]["swap_events"] >= 1
    assert m["swap"]["jerk_raw"] > 3 * clean["jerk_raw"]


def test_raw_angle_target(take) -> None:
    bad = corrupt(take, "jitter", 0.05, seed=0, target="raw_angles")
    np.testing.assert_array_equal(bad["pose3d_joints"], take["pose3d_joints"])
    assert np.std(bad["raw_angles"] - take["raw_angles"]) == pytest.approx(0.05, rel=0.1)
    again = rederive(bad, from_pose=False)
    assert M.take_metrics(again)["jerk_raw"] > 10 * M.take_metrics(take)["jerk_raw"]


def test_mirror_twice_is_identity_and_mirrors_the_arms(take) -> None:
    twice = mirror(mirror(take))
    for k in ("pose2d_keypoints", "pose3d_joints"):
        np.testing.assert_allclose(twice[k], take[k], atol=1e-4)
    once = rederive(mirror(take))
    # the left arm's roll becomes minus the right arm's roll (Pepper's sign convention)
    np.testing.assert_allclose(once["raw_angles"][:, 2], -take["raw_angles"][:, 6], atol=1e-3)


def test_window_slices_both_clocks(take) -> None:
    part = window(take, 1.0, 2.0)
    assert part["times"][0] >= 1.0 and part["times"][-1] < 2.0
    assert part["timestamps"][0] >= 1.0 and part["timestamps"][-1] < 2.0
    assert len(part["pose3d_joints"]) == len(part["timestamps"]) == len(part["raw_angles"])
    assert len(part["angles"]) == len(part["times"]) == 100


def test_rederive_reproduces_the_builder_on_a_real_take(real_dataset) -> None:
    from gesturebank.datasets import open as open_dataset

    ds = open_dataset(real_dataset)
    _, arrays = next(iter(ds))
    again = rederive(arrays)
    np.testing.assert_allclose(again["raw_angles"], arrays["raw_angles"], atol=1e-5, equal_nan=True)
    np.testing.assert_allclose(again["angles"], arrays["angles"], atol=1e-4, equal_nan=True)
