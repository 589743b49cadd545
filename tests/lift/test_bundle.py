"""The keypoint bundle adjustment (lift.multiview.bundle): cameras put off by a known amount come
back from exact projections of random points, the fixed camera stays put, and too little input
is refused in one line."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gesturebank.camera_files import CameraGroup
from gesturebank.config import MultiviewConfig
from gesturebank.errors import InputError
from gesturebank.geometry import Camera, rodrigues_to_matrix, similarity
from gesturebank.lift import TakeViews
from gesturebank.lift.multiview.bundle import camera_errors, refine_cameras, select_frames
from gesturebank.lift.multiview.lifter import MultiviewLifter
from gesturebank.lift.scoring import project_view
from gesturebank.testing.rigs import perturb_cameras

OPTIONS = MultiviewConfig()


def rig(azimuths_deg: list[float], *, radius: float = 3.0) -> CameraGroup:
    """Cameras on a circle around a person at the origin (world z up), looking at chest height,
    with some lens distortion (the refinement must take it out)."""
    cams = []
    target = np.array([0.0, 0.0, 1.2])
    for i, az in enumerate(np.radians(azimuths_deg)):
        centre = np.array([radius * np.sin(az), -radius * np.cos(az), 1.4 + 0.3 * (i % 2)])
        z = (target - centre) / np.linalg.norm(target - centre)
        x = np.cross(z, [0.0, 0.0, 1.0])
        x /= np.linalg.norm(x)
        R = np.stack([x, np.cross(z, x), z])
        K = np.array([[900.0, 0, 640.0], [0, 900.0, 360.0], [0, 0, 1]])
        dist = np.array([-0.04, 0.01, 0.0, 0.0, 0.0])
        cams.append(Camera(f"cam{i + 1}", (1280, 720), K, dist, R, -R @ centre))
    return CameraGroup(cams)


def observe(cams: CameraGroup, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact pixels (C, T, J, 2) of `points (T, J, 3)` and confidence 1."""
    px = cams.project(points)
    return px, np.ones(px.shape[:-1])


def refine(px: np.ndarray, conf: np.ndarray, cams: CameraGroup, fixed: int = 0):
    return refine_cameras(
        px,
        conf,
        cameras=cams,
        fixed=fixed,
        min_confidence=OPTIONS.bundle_min_confidence,
        max_frames=OPTIONS.bundle_frames,
        loss_px=OPTIONS.bundle_loss_px,
    )


@settings(max_examples=12, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    count=st.integers(3, 4),
    spread=st.floats(40.0, 120.0),
    fixed=st.integers(0, 2),
)
def test_perturbed_cameras_are_recovered(seed: int, count: int, spread: float, fixed: int) -> None:
    truth = rig(list(np.linspace(-spread / 2, spread / 2, count)))
    rng = np.random.default_rng(seed)
    # joints of a person moving about: 20 frames × 17 points inside a 1 m box at chest height
    points = rng.uniform([-0.4, -0.4, 0.6], [0.4, 0.4, 1.8], size=(20, 17, 3))
    px, conf = observe(truth, points)
    off = perturb_cameras(truth, rotation_deg=5.0, shift_m=0.1, seed=seed, fixed=fixed)
    rot_before, pos_before = camera_errors(off, truth)
    refined, report = refine(px, conf, off, fixed=fixed)
    rotations, positions = camera_errors(refined, truth)
    assert rotations.max() < 0.05 < rot_before.max()  # degrees
    assert positions.max() < 0.002 < pos_before.max()  # metres
    assert report.error_after_px < 0.05 < report.error_before_px
    assert report.termination == "CONVERGENCE"


def test_the_fixed_camera_and_every_intrinsic_stay() -> None:
    truth = rig([-50.0, 0.0, 50.0, 100.0])
    points = np.random.default_rng(3).uniform([-0.4, -0.4, 0.6], [0.4, 0.4, 1.8], (15, 17, 3))
    px, conf = observe(truth, points)
    off = perturb_cameras(truth, rotation_deg=5.0, shift_m=0.1, seed=7, fixed=1)
    refined, _ = refine(px, conf, off, fixed=1)
    assert np.array_equal(refined[1].R, off[1].R) and np.array_equal(refined[1].t, off[1].t)
    for before, after in zip(off, refined, strict=True):
        assert np.array_equal(before.K, after.K) and np.array_equal(before.dist, after.dist)
        assert before.name == after.name and before.size == after.size
    # the others did move, and the scale is the calibration's: the mean baseline is kept
    assert not np.allclose(refined[0].R, off[0].R)
    baseline = [np.linalg.norm(c.center - g[1].center) for g in (off, refined) for c in g]
    assert np.isclose(np.mean(baseline[:4]), np.mean(baseline[4:]))


def test_a_wrong_keypoint_pulls_little() -> None:
    truth = rig([-45.0, 0.0, 45.0])
    points = np.random.default_rng(5).uniform([-0.4, -0.4, 0.6], [0.4, 0.4, 1.8], (20, 17, 3))
    px, conf = observe(truth, points)
    px[1, ::4, 9] += 80.0  # camera 2's left wrist 80 px off in every fourth frame
    off = perturb_cameras(truth, rotation_deg=5.0, shift_m=0.1, seed=2)
    rotations, positions = camera_errors(refine(px, conf, off)[0], truth)
    assert rotations.max() < 0.2 and positions.max() < 0.01


def test_too_few_frames_is_one_line() -> None:
    truth = rig([-45.0, 0.0, 45.0])
    points = np.random.default_rng(0).uniform([-0.4, -0.4, 0.6], [0.4, 0.4, 1.8], (2, 17, 3))
    px, conf = observe(truth, points)
    with pytest.raises(InputError, match=r"^camera refinement: 2 frames .* at least 3$"):
        refine(px, conf, truth)


def test_a_camera_seeing_too_little_is_named() -> None:
    truth = rig([-45.0, 0.0, 45.0])
    points = np.random.default_rng(0).uniform([-0.4, -0.4, 0.6], [0.4, 0.4, 1.8], (10, 17, 3))
    px, conf = observe(truth, points)
    conf[2, :, 1:] = 0.1  # camera 3 is confident of the nose only
    with pytest.raises(InputError, match=r"camera 'cam3' sees 10 confident joints") as err:
        refine(px, conf, truth)
    assert "\n" not in str(err.value)


def test_one_camera_is_refused() -> None:
    truth = rig([0.0])
    px, conf = observe(truth, np.full((5, 17, 3), 1.2))
    with pytest.raises(InputError, match="needs two or more cameras, got 1"):
        refine(px, conf, truth)


def test_frames_are_confident_and_spread() -> None:
    usable = np.zeros((2, 100, 17), bool)
    usable[:, :, :10] = True
    usable[:, 40:60, 10:] = True  # a stretch with every joint: the most confident frames
    usable[:, 90:] = False
    picked = select_frames(usable, max_frames=5)
    # every seen frame has at least the median count: spread from the first to the last
    assert len(picked) == 5 and picked[0] == 0 and picked[-1] == 89
    assert np.ptp(np.diff(picked)) <= 1
    usable[:, :40, 5:] = False  # now the frames with fewer joints are below the median
    picked = select_frames(usable, max_frames=4)
    assert set(picked) <= set(range(40, 90)) and picked.min() == 40 and picked.max() == 89


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    scale=st.floats(0.2, 5.0),
    angle=st.floats(-np.pi, np.pi),
)
def test_similarity_recovers_a_known_transform(seed: int, scale: float, angle: float) -> None:
    rng = np.random.default_rng(seed)
    src = rng.normal(size=(6, 3))
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    shift = rng.normal(size=3)
    got_scale, got_rot, got_shift = similarity(src, scale * src @ rot.T + shift)
    assert np.isclose(got_scale, scale)
    assert np.allclose(got_rot, rot, atol=1e-8) and np.allclose(got_shift, shift, atol=1e-8)


def test_the_multiview_lifter_refines_on_request() -> None:
    truth = rig([-50.0, 0.0, 50.0])
    rng = np.random.default_rng(11)
    points = rng.uniform([-0.4, -0.4, 0.6], [0.4, 0.4, 1.8], size=(12, 17, 3))
    times = np.arange(12) / 30.0
    poses = [project_view(points, cam, timestamps=times) for cam in truth]
    off = perturb_cameras(truth, rotation_deg=5.0, shift_m=0.1, seed=4)
    plain = MultiviewLifter(multiview=MultiviewConfig())
    lifted, report = plain.lift_with_report(TakeViews.of(poses, off))
    assert report.bundle is None and lifted.cameras is not None
    assert np.array_equal(lifted.cameras[1].R, off[1].R)
    lifter = MultiviewLifter(multiview=MultiviewConfig(refine_cameras=True))
    lifted, report = lifter.lift_with_report(TakeViews.of(poses, off))
    assert report.bundle is not None and report.bundle.error_after_px < 0.05
    assert lifted.cameras is not None
    rotations, _ = camera_errors(CameraGroup(list(lifted.cameras)), truth)
    assert rotations.max() < 0.05
    assert np.nanmedian(report.triangulation.error) < 0.05  # the joints agree in every camera


@settings(max_examples=30, deadline=None)
@given(
    rotvec=st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3),
    scale=st.floats(0.2, 5.0),
    shift=st.lists(st.floats(-5.0, 5.0), min_size=3, max_size=3),
)
def test_camera_errors_ignore_a_similarity_of_the_world(
    rotvec: list[float], scale: float, shift: list[float]
) -> None:
    truth = rig([-45.0, 0.0, 45.0])
    rot = rodrigues_to_matrix(np.array(rotvec))
    moved = CameraGroup(
        [
            Camera(c.name, c.size, c.K, c.dist, c.R @ rot.T,
                   -(c.R @ rot.T) @ (scale * rot @ c.center + shift))
            for c in truth
        ]
    )  # fmt: skip
    rotations, positions = camera_errors(moved, truth)
    assert np.allclose(rotations, 0.0, atol=1e-4) and np.allclose(positions, 0.0, atol=1e-8)
    off = perturb_cameras(truth, rotation_deg=5.0, shift_m=0.1, seed=0)
    rotations, positions = camera_errors(off, truth)
    assert rotations.max() > 1.0 and positions.max() > 0.02
