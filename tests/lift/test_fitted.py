"""The `fitted` lifter: a synthetic perspective scene, the real 4-camera demo, and build-dataset."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize._numdiff import approx_derivative
from scipy.spatial.transform import Rotation

from gesturebank.app.extract import extract_take
from gesturebank.camera_files import Camera, CameraGroup, load_cameras
from gesturebank.config import Config, FittedConfig
from gesturebank.datasets.takes import find_calibration
from gesturebank.lift import LIFTERS, TakeViews
from gesturebank.lift.fitted import FittedLifter
from gesturebank.lift.multiview.lifter import MultiviewLifter, match_videos
from gesturebank.lift.skeleton_fit import (
    N_JOINTS,
    FitProblem,
    bone_vectors,
    ray_rotations,
    second_difference,
    skeleton_joints,
)
from gesturebank.poses import Pose2D
from gesturebank.robot.retarget import pepper_angles
from gesturebank.skeletons import COCO17

FOCAL, SIZE = 1400.0, (1280, 720)
# A person 3 m in front of the camera (camera axes: x right, y down, z forward), metres.
REST = np.array([
    [0.00, -0.20, -0.10], [0.03, -0.23, -0.08], [-0.03, -0.23, -0.08], [0.07, -0.22, 0.0],
    [-0.07, -0.22, 0.0], [0.18, 0.0, 0.0], [-0.18, 0.0, 0.0], [0.22, 0.27, -0.05],
    [-0.22, 0.27, -0.05], [0.25, 0.50, -0.15], [-0.25, 0.50, -0.15], [0.10, 0.52, 0.0],
    [-0.10, 0.52, 0.0],
])  # fmt: skip


def scene(T: int = 40, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Joints (T, 13, 3) of a gesturing person in the camera frame, and timestamps (T,): the
    forearms swing towards and away from the camera, the body turns a little."""
    rng = np.random.default_rng(seed)
    times = np.arange(T) / 30.0
    bones = np.repeat(bone_vectors(REST[None])[..., :], T, axis=0)
    for t, s in enumerate(times):
        for arm, sign in ((4, 1), (6, -1)):  # forearms: about the shoulder line and up
            rot = Rotation.from_euler("xy", [1.2 * np.sin(2 * s + sign), 0.6 * np.sin(3 * s)])
            bones[t, arm] = rot.apply(bones[t, arm])
        turn = Rotation.from_euler("y", 0.3 * np.sin(s) + rng.normal(0, 0.01))
        bones[t] = turn.apply(bones[t])
    neck = np.stack([0.1 * np.sin(times), 0.05 * np.cos(times), 3.0 + 0.1 * times], axis=1)
    return skeleton_joints(neck, bones), times


def pose2d(joints: np.ndarray, times: np.ndarray, prior: np.ndarray | None) -> Pose2D:
    """Pinhole image of joints (T, 13, 3) as a COCO-17 Pose2D, with `prior` as world landmarks."""
    T = len(joints)
    kp = np.full((T, 17, 3), np.nan, np.float32)
    kp[:, :N_JOINTS, :2] = FOCAL * joints[..., :2] / joints[..., 2:] + np.array(SIZE) / 2
    kp[:, :N_JOINTS, 2] = 0.9
    world = None
    if prior is not None:
        world = np.full((T, 17, 3), np.nan, np.float32)
        world[:, :N_JOINTS] = prior
    return Pose2D(kp, times, COCO17.name, SIZE, world)


def blazepose_like(joints: np.ndarray) -> np.ndarray:
    """The true joints as BlazePose's world landmarks would be: hips-centred, seen along the ray
    through the person (its axes turned off the camera's by the ray's angle)."""
    neck = (joints[:, 5] + joints[:, 6]) / 2
    ray = ray_rotations(FOCAL * neck[:, :2] / neck[:, 2:] + np.array(SIZE) / 2,
                        np.array([FOCAL, FOCAL]), center=np.array(SIZE) / 2)  # fmt: skip
    return np.einsum("tji,tkj->tki", ray, joints - joints[:, 11:13].mean(axis=1, keepdims=True))


def camera() -> Camera:
    K = np.array([[FOCAL, 0, SIZE[0] / 2], [0, FOCAL, SIZE[1] / 2], [0, 0, 1]])
    return Camera("synthetic", SIZE, K, np.zeros(5), np.eye(3), np.zeros(3))


def view(pose: Pose2D, cam: Camera | None = None) -> TakeViews:
    """One view, calibrated by `cam` when given."""
    return TakeViews.of(pose, None if cam is None else CameraGroup([cam]))


def fixed_lengths() -> FittedConfig:
    return FittedConfig(length_weight=None, smoothness=0.0)


def test_jacobian_is_the_derivative_of_the_residuals() -> None:
    rng = np.random.default_rng(1)
    T = 5
    prior = rng.normal(size=(T, 12, 3))
    prior /= np.linalg.norm(prior, axis=-1, keepdims=True)
    for length_weight in (None, 3.0):
        problem = FitProblem(
            observed=rng.normal(500, 50, (T, 13, 2)),
            weight=rng.uniform(size=(T, 13)),
            prior=prior,
            prior_weight=rng.uniform(0, 10, (T, 12)),
            lengths=rng.uniform(0.1, 0.5, 12),
            focal=np.array([1000.0, 1010.0]),
            center=np.array([500.0, 600.0]),
            accel=second_difference(np.cumsum(rng.uniform(0.01, 0.05, T))),
            smoothness=0.1,
            length_weight=length_weight,
        )
        x = rng.normal(size=(T, 13, 3))
        x[:, 0, 2] = 3.0
        flat = x.ravel() if length_weight is None else np.r_[x.ravel(), rng.uniform(0.1, 0.5, 12)]
        numeric = approx_derivative(problem.residuals, flat, method="3-point")
        np.testing.assert_allclose(problem.jacobian(flat).toarray(), numeric, atol=1e-5 * 3000)


def test_exact_recovery_under_perspective() -> None:
    """A prior with the true bones (hips-centred, as BlazePose's): the fit recovers the pose in
    the camera frame — calibrated, and from the default field of view when it matches."""
    joints, times = scene()
    prior = blazepose_like(joints)
    for cam in (camera(), None):
        fov = np.rad2deg(2 * np.arctan(max(SIZE) / 2 / FOCAL))
        opts = fixed_lengths().model_copy(update={"fov_deg": fov})
        lifted, report = FittedLifter(fitted=opts).lift_with_report(
            view(pose2d(joints, times, prior), cam)
        )
        err = np.linalg.norm(lifted.joints[:, :N_JOINTS] - joints, axis=-1)
        print(f"\nmax error {1000 * err.max():.1f} mm, max reprojection "
              f"{np.nanmax(report.reprojection_px):.2f} px")  # fmt: skip
        assert err.max() < 0.005  # metres
        assert np.nanmax(report.reprojection_px) < 0.5
        assert not report.flagged_frames.any()
        assert np.isnan(lifted.joints[:, 13:]).all()  # no legs


def test_the_image_corrects_a_noisy_prior() -> None:
    """Bone directions 10° off at random: the fitted bones are nearer the truth than the prior,
    and the arms' lengths (15 % short in the prior) are refitted towards the truth — in
    proportion to the torso: one view cannot see the overall scale."""
    joints, times = scene(T=60)
    rng = np.random.default_rng(2)
    truth = bone_vectors(joints)
    lengths = np.linalg.norm(truth, axis=-1)
    noise = Rotation.from_rotvec(rng.normal(0, np.deg2rad(10) / np.sqrt(2), (60 * 12, 3)))
    bones = noise.apply(truth.reshape(-1, 3)).reshape(truth.shape)
    bones[:, 3:7] *= 0.85  # upper arms and forearms
    prior = skeleton_joints(np.zeros((60, 3)), bones)
    lifted, report = FittedLifter().lift_with_report(view(pose2d(joints, times, prior), camera()))
    fitted = bone_vectors(lifted.joints.astype(np.float64))

    def angle(a: np.ndarray) -> float:
        cos = np.sum(a * truth, -1) / np.linalg.norm(a, axis=-1) / lengths
        return float(np.rad2deg(np.median(np.arccos(np.clip(cos, -1, 1)))))

    got = np.array(list(report.bone_lengths.values()))
    arms = got[3:7] / got[1] / (lengths[0, 3:7] / lengths[0, 1])  # relative to the spine
    print(f"\nbone direction error: prior {angle(bones):.1f}°, fitted {angle(fitted):.1f}°; "
          f"arm proportions {np.round(arms, 3)} (prior 0.85)")  # fmt: skip
    assert angle(fitted) < 0.5 * angle(bones)
    assert np.abs(arms - 1).max() < 0.05


def test_a_prior_pointing_the_wrong_way_is_flagged() -> None:
    joints, times = scene(T=20)
    prior = joints.copy()
    prior[:, 9] = 2 * joints[:, 7] - joints[:, 9]  # the left forearm the other way round
    lifter = FittedLifter(fitted=fixed_lengths())
    _, report = lifter.lift_with_report(view(pose2d(joints, times, prior)))
    assert report.disagree[:, COCO17.index["left_wrist"]].all()
    assert not report.disagree[:, COCO17.index["right_wrist"]].any()


@pytest.mark.parametrize("seed", range(3))
def test_invariant_to_the_prior_s_translation_and_equivariant_to_a_turn(seed: int) -> None:
    """The prior counts only through its bone vectors: moving it changes nothing. A scene turned
    about the camera's centre is lifted turned (within the fit's tolerance)."""
    rng = np.random.default_rng(seed)
    joints, times = scene(T=20, seed=seed)
    lifter = FittedLifter(fitted=fixed_lengths())
    prior = blazepose_like(joints)
    base = lifter.lift(view(pose2d(joints, times, prior), camera())).joints
    moved = lifter.lift(view(pose2d(joints, times, prior + rng.normal(0, 1, 3)), camera())).joints
    np.testing.assert_allclose(moved, base, atol=1e-4)
    turn = Rotation.from_rotvec(rng.normal(0, 0.05, 3))
    turned = turn.apply(joints.reshape(-1, 3)).reshape(joints.shape)
    lifted = lifter.lift(view(pose2d(turned, times, blazepose_like(turned)), camera()))
    out = lifted.joints[:, :N_JOINTS]
    expected = turn.apply(base[:, :N_JOINTS].reshape(-1, 3)).reshape(out.shape)
    assert np.abs(out - expected).max() < 0.005


def test_without_world_landmarks_the_geometric_prior_is_used() -> None:
    joints, times = scene(T=15)
    lifted, report = FittedLifter().lift_with_report(view(pose2d(joints, times, None)))
    assert report.prior == "geometric" and lifted.frame == "camera"
    assert np.isfinite(lifted.joints[:, :N_JOINTS]).all()
    assert np.nanmedian(report.reprojection_px) < 5.0


def test_beats_blazepose_world_on_a_real_demo_camera(samples: Path) -> None:
    """Pepper angles from cam03 alone against the 4-camera reference (benchmarks/fidelity.py
    has every camera)."""
    root = samples / "pose2sim" / "Demo_SinglePerson"
    cams = load_cameras(find_calibration(root))
    full_rate = Config.model_validate({"video": {"max_fps": None}})  # as the demo tests: cached
    videos = match_videos(cams, sorted((root / "videos").glob("*.mp4")))
    poses = [extract_take(v, full_rate, with_audio=False).tracked.pose for v in videos]
    reference = pepper_angles(MultiviewLifter().lift(TakeViews.of(poses, cams)))

    def error(angles: np.ndarray) -> float:
        d = np.abs(angles - reference)
        return float(np.rad2deg(np.nanmean(np.minimum(d, 2 * np.pi - d))))

    fitted = error(pepper_angles(FittedLifter().lift(view(poses[2], cams[2]))))
    learned = error(pepper_angles(LIFTERS.create("blazepose-world", Config()).lift(view(poses[2]))))
    print(f"\ncam03: fitted {fitted:.1f} deg, blazepose-world {learned:.1f} deg")
    assert fitted < learned


def test_selectable_in_build_dataset(samples: Path, tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    assert "fitted" in LIFTERS.names()
    videos, out = tmp_path / "videos", tmp_path / "out"
    videos.mkdir()
    shutil.copy(samples / "talking" / "lab" / "cam01_arctic.mp4", videos / "take.mp4")
    build = Path(sys.executable).parent / "build-dataset"
    cmd = [str(build), str(videos), str(out), "--lifter", "fitted", "--quiet",
           "--set", "video.end_s=8"]  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    rows = [r for r in pq.read_table(out / "manifest.parquet").to_pylist() if r["kind"] == "clip"]
    assert rows and {r["lifter"] for r in rows} == {"fitted"}
    assert any(r["qc_status"] == "accepted" for r in rows), rows
