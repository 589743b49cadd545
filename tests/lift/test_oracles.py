"""The floors' oracles (issue 39): a lift whose arm bones point the wrong way in depth gets the
true signs back with its image kept, a lift tilted towards the camera gets the true tilt (its
hips turned back, its arms kept), and the 2D put at the true depths is the truth."""

from __future__ import annotations

import numpy as np

from gesturebank.camera_files import Camera
from gesturebank.lift.scoring import (
    angle_error_deg,
    at_true_depth,
    averaged_directions,
    sign_errors,
    torso_tilt_deg,
    with_nearer_directions,
    with_true_depth_signs,
    with_true_tilt,
)
from gesturebank.lift.training.lifter_motion import gesture_take
from gesturebank.skeletons import COCO17

# a person facing the camera 3 m away: world (forward, left, up) → camera (right, down, forward)
TO_CAMERA = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0]])
LS, LE, LW = (COCO17.index[f"left_{j}"] for j in ("shoulder", "elbow", "wrist"))
# a camera at the origin of those axes (its world is the camera's own frame)
CAMERA = Camera("truth", (1280, 720), np.array([[1000.0, 0.0, 640.0], [0.0, 1000.0, 360.0],
                [0.0, 0.0, 1.0]]), np.zeros(0), np.eye(3), np.zeros(3))  # fmt: skip


def _seen(seed: int) -> np.ndarray:
    """(60, 17, 3) made-up gesture motion in the axes of a camera 3 m in front of it."""
    world = gesture_take(np.random.default_rng(seed), 60)
    return world @ TO_CAMERA.T + np.array([0.0, 0.0, 3.0])


def _image(joints: np.ndarray) -> np.ndarray:
    return joints[..., :2] / joints[..., 2:]


def _reflected(joints: np.ndarray, parent: int, carried: list[int]) -> np.ndarray:
    """`joints` with the bone from `parent` reflected across the plane normal to the ray through
    `parent`: the frontal ambiguity's other answer."""
    out = joints.copy()
    ray = out[:, parent] / np.linalg.norm(out[:, parent], axis=-1, keepdims=True)
    along = np.sum((out[:, carried[0]] - out[:, parent]) * ray, -1)
    out[:, carried] -= 2.0 * (along[:, None] * ray)[:, None]
    return out


def test_true_depth_signs_undo_a_bone_turned_the_wrong_way() -> None:
    truth = _seen(0)
    wrong = _reflected(truth, LS, [LE, LW])
    # the wrong answer looks (nearly) the same from the camera, yet its depth signs are wrong
    assert np.abs(_image(wrong) - _image(truth)).max() < 0.02
    deep, flipped = sign_errors(wrong, truth, camera=CAMERA)["L upper arm"]
    assert deep > 0 and flipped == deep
    assert np.allclose(with_true_depth_signs(wrong, truth), truth)
    assert np.allclose(with_true_depth_signs(truth, truth), truth)  # right signs: untouched


def test_the_true_2d_at_true_depth_is_the_truth() -> None:
    truth = _seen(2)
    pixels = CAMERA.project(truth)
    assert np.allclose(at_true_depth(pixels, camera=CAMERA, truth_camera=truth), truth)
    nudged = pixels + np.array([10.0, 0.0])  # 10 px to the right: x moves by 10 / f of the depth
    moved = at_true_depth(nudged, camera=CAMERA, truth_camera=truth) - truth
    assert np.allclose(moved[..., 0], 0.01 * truth[..., 2]) and np.allclose(moved[..., 1:], 0)


def test_true_tilt_undoes_a_torso_leaning_the_wrong_way() -> None:
    truth = _seen(1)
    turn = np.deg2rad(15.0)  # the whole body tilted 15° towards the camera about the neck
    neck = truth[:, [5, 6]].mean(axis=1, keepdims=True)
    rot = np.array([[1, 0, 0], [0, np.cos(turn), -np.sin(turn)], [0, np.sin(turn), np.cos(turn)]])
    tilted = neck + (truth - neck) @ rot.T
    assert np.abs(torso_tilt_deg(tilted) - torso_tilt_deg(truth)).min() > 14.0
    hips = with_true_tilt(tilted, truth)
    assert np.allclose(torso_tilt_deg(hips), torso_tilt_deg(truth))
    assert np.allclose(hips[:, :11], tilted[:, :11])  # the arms and face stay as lifted
    assert np.allclose(hips[:, 11:], truth[:, 11:])  # the hips turned back where they were


def test_angle_errors_are_periodic_however_many_turns_apart() -> None:
    """A lifter's ElbowYaw is unwrapped over time, so it can lie turns away from the truth's:
    the error is still the shorter way round, never negative (benchmarks' Pose2Sim means)."""
    truth = np.deg2rad(np.array([10.0, -170.0, 0.0]))
    lifted = truth + np.deg2rad(np.array([20.0 + 720.0, -30.0 - 360.0, 190.0]))
    np.testing.assert_allclose(angle_error_deg(lifted, truth), [20.0, 30.0, 170.0], atol=1e-9)


def test_two_lifts_combined_bone_by_bone_keep_the_first_ones_lengths() -> None:
    """The net's lift with its left upper arm the wrong way, and a second lift (BlazePose's world
    landmarks: the hips as origin) with it right: the oracle takes the nearer direction of each
    bone, the average mixes them (weight on the first), each from the first lift's neck."""
    truth = _seen(0)
    wrong = _reflected(truth, LS, [LE, LW])
    other = truth - truth[:, [11, 12]].mean(axis=1, keepdims=True)
    assert np.allclose(with_nearer_directions(wrong, other, truth_camera=truth), truth)
    assert np.allclose(averaged_directions(wrong, other, weight=1.0), wrong)
    assert np.allclose(averaged_directions(wrong, other, weight=0.0), truth)
    half = averaged_directions(wrong, other, weight=0.5)
    unit = [(j[:, LE] - j[:, LS]) / np.linalg.norm(j[:, LE] - j[:, LS], axis=-1, keepdims=True)
            for j in (half, wrong, truth)]  # fmt: skip
    turned = np.sum(unit[1] * unit[2], axis=-1) < 0.99
    assert turned.any()  # the half way bisects the two directions where they differ
    np.testing.assert_allclose(np.sum(unit[0] * unit[1], -1), np.sum(unit[0] * unit[2], -1))
    np.testing.assert_allclose(np.linalg.norm(half[:, LE] - half[:, LS], axis=-1),
                               np.linalg.norm(truth[:, LE] - truth[:, LS], axis=-1))  # fmt: skip
    unseen = other.copy()
    unseen[:, LE] = np.nan  # a bone the second lift lacks keeps the first's direction
    assert np.allclose(averaged_directions(wrong, unseen, weight=0.0), wrong)
