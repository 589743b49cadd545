"""The learned lifter's training pairs: the camera that sees a person keeps their shoulders in its
picture and stays away from them, so the network's inputs stay bounded (a camera the mocap's
person walked up to gave inputs of thousands of torso sizes, and the batch norms learned from
them made the exported model lift an average pose); the 2D error is a detector's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturebank.lift.learned import features as F
from gesturebank.mocap.bvh import read_bvh
from gesturebank.mocap.pose import motion_pose

pytest.importorskip("torch")
from gesturebank.lift.training.lifter_motion import gesture_take
from gesturebank.lift.training.lifter_net import UP, Sampler
from gesturebank.lift.training.lifter_views import (
    MIN_DEPTH_M,
    CameraRanges,
    detector_noise,
    view_batch,
)


def test_a_kept_camera_sees_the_shoulders_and_comes_no_nearer_than_the_minimum() -> None:
    rng = np.random.default_rng(3)
    takes = [gesture_take(rng, 60) for _ in range(48)]
    uv, local, outside, seen = view_batch(takes, [UP] * len(takes), rng=rng, cams=CameraRanges())
    assert seen.mean() > 0.9
    for k in np.flatnonzero(seen):
        spine = np.median(np.linalg.norm(takes[k][:, 5:7].mean(1) - takes[k][:, 11:13].mean(1),
                                         axis=-1))  # fmt: skip
        assert (local[k][..., 2] > MIN_DEPTH_M * spine / 0.5).all()
        assert not outside[k][:, 5:7].all()
    # the person anywhere in the picture, sometimes partly outside it
    assert 0.0 < outside[seen].mean() < 0.3
    # half read with the true focal: those rays are the camera-frame joints' own
    rays = local[..., :2] / local[..., 2:3]
    exact = np.isclose(uv, rays, atol=1e-9).all(axis=(1, 2, 3))
    assert 0.2 < exact[seen].mean() < 0.9


def test_detector_noise_drops_and_swaps_but_keeps_the_torso() -> None:
    rng = np.random.default_rng(5)
    takes = [gesture_take(rng, 176) for _ in range(16)]
    uv, local, outside, _ = view_batch(takes, [UP] * len(takes), rng=rng, cams=CameraRanges())
    noisy = np.stack(
        [detector_noise(uv[k], local[k], outside=outside[k], rng=rng) for k in range(16)]
    )
    assert np.isfinite(noisy[..., [5, 6, 11, 12], :]).all()
    missing = np.isnan(noisy).any(-1).mean()
    assert 0.002 < missing < 0.2
    spine = np.linalg.norm(uv[:, :, 5:7].mean(2) - uv[:, :, 11:13].mean(2), axis=-1)
    err = np.linalg.norm(noisy - uv, axis=-1) / spine[..., None]
    assert 0.02 < np.nanmedian(err) < 0.15  # BlazePose-sized error, in spine lengths


def test_training_inputs_stay_bounded(samples: Path) -> None:
    whole = motion_pose(read_bvh(samples / "bvhtools/testBvhFiles/test.bvh"))[0]
    grid = np.arange(51.0, whole.timestamps[-1], 1 / F.RATE_HZ)  # where the person walks about
    take = F.resample(whole.joints.astype(np.float64), whole.timestamps, at=grid)
    sampler = Sampler([take], frames=176)
    x, y = sampler.batch(np.random.default_rng(1), 96)
    # in torso sizes about the neck (and the neck's ray coordinates): a person in a 60° picture
    assert np.isfinite(x).all() and np.abs(x).max() < 8.0
    assert np.abs(y).max() < 3.0
