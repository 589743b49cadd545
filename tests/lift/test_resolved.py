"""The `resolved` lifter: depth-sign readings and their decoding, mirror symmetry, real mocap."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gesturebank.camera_files import CameraGroup
from gesturebank.config import Config
from gesturebank.lift import LIFTERS, TakeViews
from gesturebank.lift.depth_sign import decode_path, ray_candidates, rays
from gesturebank.lift.scoring import (
    look_at,
    mirror_angles,
    mirror_view,
    project_view,
    score_angles,
    score_lift,
)
from gesturebank.mocap.bvh import read_bvh
from gesturebank.mocap.pose import body_axes, motion_pose
from gesturebank.robot.retarget import pepper_angles

FOCAL, CENTER = np.array([1100.0, 1100.0]), np.array([640.0, 360.0])
unit = st.floats(-1, 1, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(
    st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), st.floats(2.0, 5.0)),
    st.tuples(unit, unit, unit).filter(lambda v: np.linalg.norm(v) > 0.1),
    st.floats(0.1, 0.5),
)
def test_one_reading_is_the_true_child_and_both_look_the_same(
    parent: tuple[float, float, float], direction: tuple[float, float, float], length: float
) -> None:
    p = np.array(parent)
    child = p + length * np.array(direction) / np.linalg.norm(direction)
    pixel = FOCAL * child[:2] / child[2] + CENTER
    near, far = ray_candidates(p, rays(pixel, FOCAL, center=CENTER), length=length)
    assert min(np.linalg.norm(near - child), np.linalg.norm(far - child)) < 1e-6
    for reading in (near, far):
        assert np.linalg.norm(reading - p) == pytest.approx(length, rel=1e-6)
        assert FOCAL * reading[:2] / reading[2] + CENTER == pytest.approx(pixel, abs=1e-6)
    assert near[2] <= far[2]


@settings(max_examples=40, deadline=None)
@given(st.floats(0.2, 1.0), st.floats(0.4, 0.8), st.floats(0.0, 6.0))
def test_decoding_follows_a_bone_through_the_image_plane(
    hz: float, tilt: float, phase: float
) -> None:
    """A forearm swinging towards and away from the camera through the image plane: its two
    readings per frame, no evidence but at the first clearly tilted frame. The decoded path is
    the true one: a bone keeps swinging through the plane rather than bouncing back off it.
    (A bone that only grazes the plane and turns back is ambiguous to any temporal prior.)"""
    times = np.arange(90) / 30.0
    angle = tilt * np.sin(2 * np.pi * hz * times + phase)
    parent = np.tile([0.2, 0.0, 3.0], (len(times), 1))
    child = parent + 0.25 * np.stack([np.cos(angle), np.zeros_like(angle), np.sin(angle)], 1)
    pixels = FOCAL * child[:, :2] / child[:, 2:] + CENTER
    near, far = ray_candidates(parent, rays(pixels, FOCAL, center=CENTER), length=0.25)
    readings = np.stack([near, far], axis=1)[:, :, None]  # (T, 2, 1, 3)
    truth = np.argmin(np.linalg.norm(readings[:, :, 0] - child[:, None], axis=-1), axis=1)
    deep = np.abs(np.sin(angle)) > 0.3  # elsewhere the two readings nearly coincide
    unary = np.zeros((len(times), 2))
    first = int(np.argmax(deep))
    unary[first, 1 - truth[first]] = 100.0
    path = decode_path(readings, unary, times=times, speed=1.5, accel=20.0)
    assert np.mean(path[deep] == truth[deep]) >= 0.95


def _mocap(samples: Path, start: float, end: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    whole = motion_pose(read_bvh(samples / "bvhtools/testBvhFiles/test.bvh"))[0]
    front, _, up = body_axes(whole.joints)
    pick = (whole.timestamps >= start) & (whole.timestamps < end)
    return whole.joints[pick].astype(np.float64), whole.timestamps[pick], np.stack([front, up])


def _camera(joints: np.ndarray, axes: np.ndarray, azimuth_deg: float):
    front, up = axes
    chest = np.nanmean(joints[:, 5:7].mean(axis=1), axis=0) - 0.15 * up
    a = np.deg2rad(azimuth_deg)
    eye = chest + 3.0 * (np.cos(a) * front + np.sin(a) * np.cross(up, front))
    return look_at(eye=eye, target=chest, up=up, size=(1280, 720), fov_deg=60.0)


def test_a_mirrored_view_lifts_to_the_mirrored_motion(samples: Path) -> None:
    joints, times, axes = _mocap(samples, 31.0, 35.0)
    cam = _camera(joints, axes, 30.0)
    view = project_view(joints, cam, timestamps=times)
    lifter = LIFTERS.create("resolved", Config())
    config = Config().retarget
    lifted = pepper_angles(lifter.lift(TakeViews.of(view, CameraGroup([cam]))), config=config)
    flipped = lifter.lift(TakeViews.of(mirror_view(view), CameraGroup([cam])))
    back = mirror_angles(pepper_angles(flipped, config=config))
    assert np.nanmean(score_angles(back, lifted)[0]) < 0.5  # measured: 0.0°


# Measured on test.bvh 31–37 s from the true 2D (scoring.score_lift): hand cm, wrong-sign %.
MEASURED = {0.0: (3.6, 0.0), 60.0: (11.0, 30.4)}  # fitted: 16.3 / 27.0 cm


@pytest.mark.parametrize("azimuth", sorted(MEASURED))
def test_perfect_2d_of_real_mocap_bounds_hand_error_and_flips(
    samples: Path, azimuth: float
) -> None:
    joints, times, axes = _mocap(samples, 31.0, 37.0)
    cam = _camera(joints, axes, azimuth)
    config = Config()
    views = TakeViews.of(project_view(joints, cam, timestamps=times), CameraGroup([cam]))
    score = score_lift(LIFTERS.create("resolved", config).lift(views), joints, camera=cam,
                       retarget=config.retarget)  # fmt: skip
    fitted = score_lift(LIFTERS.create("fitted", config).lift(views), joints, camera=cam,
                        retarget=config.retarget)  # fmt: skip
    hand, flips = MEASURED[azimuth]
    assert score.hand_cm <= 1.5 * hand
    assert score.wrong_sign_pct <= 1.5 * flips + 2.0
    assert score.hand_cm < fitted.hand_cm


def test_scoring_the_truth_itself_scores_zero(samples: Path) -> None:
    joints, times, axes = _mocap(samples, 31.0, 32.0)
    cam = _camera(joints, axes, 60.0)
    from gesturebank.poses import Pose3D

    truth_in_camera = Pose3D(cam.to_camera(joints), np.ones(joints.shape[:2]), times)
    score = score_lift(truth_in_camera, joints, camera=cam, retarget=Config().retarget)
    assert score.hand_cm < 1e-3 and score.wrong_sign_pct == 0.0
    assert np.nanmax(score.angle_error_deg) < 1e-2
    assert score.head_deg < 1e-2 and np.allclose(score.head_bias, 0.0, atol=1e-2)


def test_the_learned_nets_bones_as_evidence_resolve_the_60_degree_view(samples: Path) -> None:
    """`resolved.learned_weight`: each decoded bone held near the learned lifter's lift of the
    same 2D. Measured at 60° on test.bvh 31–37 s from true 2D: 11.0 cm and 30 % wrong signs
    without, 2.5 cm and none with a weight of 16."""
    joints, times, axes = _mocap(samples, 31.0, 37.0)
    cam = _camera(joints, axes, 60.0)
    views = TakeViews.of(project_view(joints, cam, timestamps=times), CameraGroup([cam]))
    scores = []
    for weight in (0.0, 16.0):
        config = Config.model_validate({"lifter": {"resolved": {"learned_weight": weight}}})
        lifted = LIFTERS.create("resolved", config).lift(views)
        scores.append(score_lift(lifted, joints, camera=cam, retarget=config.retarget))
    alone, guided = scores
    assert guided.hand_cm <= 1.5 * 2.5 < alone.hand_cm
    assert guided.wrong_sign_pct <= 2.0 < alone.wrong_sign_pct
