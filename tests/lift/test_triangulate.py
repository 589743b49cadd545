"""Triangulation on synthetic scenes: known skeleton, known cameras, noise, a corrupted camera."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gesturebank.camera_files import Camera, CameraGroup
from gesturebank.config import MultiviewConfig
from gesturebank.errors import InputError
from gesturebank.lift.multiview import triangulate as tri_mod
from gesturebank.lift.multiview.refine import refine
from gesturebank.lift.multiview.robust import Views, fix_swaps, make_consistent, relabel, untangle
from gesturebank.lift.multiview.triangulate import Triangulation, dlt, triangulate
from gesturebank.skeletons import COCO17


def fl(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


# A standing person in metres (x right, y forward, z up), 17 COCO joints, roughly to scale.
SKELETON = np.array(
    [
        [0.00, 0.05, 1.65],  # nose
        [0.03, 0.03, 1.68], [-0.03, 0.03, 1.68],  # eyes
        [0.07, -0.02, 1.66], [-0.07, -0.02, 1.66],  # ears
        [0.19, 0.0, 1.45], [-0.19, 0.0, 1.45],  # shoulders
        [0.24, 0.05, 1.18], [-0.24, 0.05, 1.18],  # elbows
        [0.26, 0.20, 1.00], [-0.26, 0.20, 1.00],  # wrists
        [0.11, 0.0, 0.95], [-0.11, 0.0, 0.95],  # hips
        [0.12, 0.02, 0.50], [-0.12, 0.02, 0.50],  # knees
        [0.12, 0.0, 0.08], [-0.12, 0.0, 0.08],  # ankles
    ]
)  # fmt: skip


def solve(
    pixels: np.ndarray, confidence: np.ndarray, cameras: CameraGroup, **options: float
) -> Triangulation:
    """`triangulate` with the `multiview` section's defaults, `options` changed."""
    cfg = MultiviewConfig()
    defaults = {
        "min_confidence": cfg.min_confidence,
        "max_error_px": cfg.max_error_px,
        "min_cameras": cfg.min_cameras,
        "max_combinations": cfg.max_combinations,
    }
    return triangulate(pixels, confidence, cameras=cameras, **(defaults | options))  # type: ignore[arg-type]


def look_at(center: np.ndarray, target: np.ndarray, name: str, f: float = 1400.0) -> Camera:
    """An OpenCV camera at `center` looking at `target` with world z up; 1920x1080."""
    z = target - center
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    K = np.array([[f, 0, 960.0], [0, f, 540.0], [0, 0, 1]])
    dist = np.array([-0.05, 0.02, 0.0005, -0.0003, 0.0])
    return Camera(name, (1920, 1080), K, dist, R, -R @ center)


def ring(n: int, radius: float = 4.0) -> CameraGroup:
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    target = np.array([0.0, 0.0, 1.0])
    return CameraGroup(
        [
            look_at(np.array([radius * np.cos(a), radius * np.sin(a), 1.6]), target, f"c{i}")
            for i, a in enumerate(angles)
        ]
    )


def motion(T: int, rng: np.random.Generator) -> np.ndarray:
    """(T, 17, 3): the skeleton drifting and swaying."""
    t = np.linspace(0, 2, T)[:, None, None]
    sway = np.concatenate([0.2 * np.sin(2 * t), 0.1 * np.cos(3 * t), 0 * t], axis=-1)
    return SKELETON[None] + sway + rng.normal(0, 0.01, (T, 17, 3))


def test_noiseless_views_are_recovered_exactly() -> None:
    rng = np.random.default_rng(0)
    cams = ring(4)
    X = motion(10, rng)
    px = cams.project(X)
    res = solve(px, np.ones(px.shape[:-1]), cams)
    np.testing.assert_allclose(res.points, X, atol=1e-6)
    assert np.nanmax(res.error) < 1e-4
    assert res.used.all()


def test_noise_and_a_corrupted_camera_is_excluded() -> None:
    rng = np.random.default_rng(1)
    cams = ring(6)
    X = motion(30, rng)
    px = cams.project(X) + rng.normal(0, 1.0, (6, 30, 17, 2))  # 1 px detector noise
    px[3] += np.array([45.0, -30.0])  # camera 3 is badly off (e.g. a wrong person)
    conf = rng.uniform(0.6, 1.0, px.shape[:-1])
    res = solve(px, conf, cams, max_error_px=8.0)
    err3d = np.linalg.norm(res.points - X, axis=-1)
    # 1 px at 4 m with f = 1400 is ~3 mm; five good views average it down further.
    assert np.median(err3d) < 0.005 and err3d.max() < 0.02
    assert res.used[3].mean() < 0.02
    assert res.used[[0, 1, 2, 4, 5]].mean() > 0.95
    assert np.median(res.error) < 2.0
    # Without exclusion the same data is far worse: the test above can fail.
    naive = solve(px, conf, cams, max_error_px=1e9)
    assert np.median(np.linalg.norm(naive.points - X, axis=-1)) > 3 * np.median(err3d)


def test_low_confidence_and_missing_views_are_ignored() -> None:
    cams = ring(3)
    X = motion(5, np.random.default_rng(2))
    px = cams.project(X)
    conf = np.ones(px.shape[:-1])
    px[0, :, 0] = np.nan  # nose never seen by camera 0
    conf[1, :, 0] = 0.1  # … and barely by camera 1
    res = solve(px, conf, cams, min_confidence=0.3)
    assert np.isnan(res.points[:, 0]).all() and np.isnan(res.error[:, 0]).all()
    assert not res.used[:, :, 0].any()
    np.testing.assert_allclose(res.points[:, 1:], X[:, 1:], atol=1e-6)
    # A garbage observation with low confidence does not pull the estimate.
    px[2, :, 5] += 300.0
    conf[2, :, 5] = 0.05
    res = solve(px, conf, cams, min_confidence=0.3)
    np.testing.assert_allclose(res.points[:, 5], X[:, 5], atol=1e-6)


def test_min_cameras_is_respected() -> None:
    rng = np.random.default_rng(3)
    cams = ring(5)
    X = motion(8, rng)
    px = cams.project(X) + rng.normal(0, 25.0, (5, 8, 17, 2))  # hopeless noise: never under 1 px
    res = solve(px, np.ones(px.shape[:-1]), cams, max_error_px=1.0, min_cameras=3)
    assert res.n_cameras.min() >= 3


def test_many_cameras_search_is_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    """12 cameras, 3 corrupted: the subsets evaluated stay within the cap per point, and the
    corrupted cameras are still dropped (greedily, once the exhaustive budget is spent)."""
    rng = np.random.default_rng(4)
    cams = ring(12, radius=5.0)
    X = motion(10, rng)
    px = cams.project(X) + rng.normal(0, 0.5, (12, 10, 17, 2))
    bad = [2, 7, 9]
    px[bad] += rng.uniform(40, 80, (3, 1, 1, 2)) * rng.choice([-1, 1], (3, 1, 1, 2))
    solved = []
    real_dlt = tri_mod.dlt

    def counting_dlt(
        normalised: np.ndarray, extrinsics: np.ndarray, *, weights: np.ndarray
    ) -> np.ndarray:
        solved.append(normalised.shape[1])
        return real_dlt(normalised, extrinsics, weights=weights)

    monkeypatch.setattr(tri_mod, "dlt", counting_dlt)
    cap = 20
    res = solve(px, np.ones(px.shape[:-1]), cams, max_error_px=5.0, max_combinations=cap)
    n_points = 10 * 17
    # Exhaustive levels stop at the cap; each greedy level costs one solve per point.
    assert sum(solved) <= n_points * (1 + cap + 12)
    # The full search would be 2^12 − 1 − 12 subsets per point; we did a tiny fraction.
    assert sum(solved) < n_points * 100
    assert res.used[bad].mean() < 0.05
    assert np.median(np.linalg.norm(res.points - X, axis=-1)) < 0.005


@st.composite
def scenes(draw: st.DrawFn) -> tuple[CameraGroup, np.ndarray]:
    """2–6 cameras at random places around a random cloud of points they all see."""
    n_cams = draw(st.integers(2, 6))
    cams = []
    for i in range(n_cams):
        az = draw(fl(0, 2 * np.pi))
        el = draw(fl(-0.6, 0.9))
        dist = draw(fl(2.0, 10.0))
        center = dist * np.array([np.cos(az) * np.cos(el), np.sin(az) * np.cos(el), np.sin(el)])
        target = np.array(draw(st.lists(fl(-0.3, 0.3), min_size=3, max_size=3)))
        f = draw(fl(500, 3000))
        cams.append(look_at(center, target, f"c{i}", f=f))
    seed = draw(st.integers(0, 2**32 - 1))
    pts = np.random.default_rng(seed).uniform(-0.5, 0.5, (draw(st.integers(1, 40)), 3))
    return CameraGroup(cams), pts


def _well_separated(cams: CameraGroup) -> bool:
    """Every pair of optical centres subtends > 5° at the origin (else depth is ill-posed)."""
    c = np.stack([cam.center / np.linalg.norm(cam.center) for cam in cams])
    cos = np.clip(c @ c.T, -1, 1)
    return bool((cos[np.triu_indices(len(c), 1)] < np.cos(np.radians(5))).all())


@settings(max_examples=80, deadline=None)
@given(scene=scenes())
def test_projection_triangulation_round_trip(scene: tuple[CameraGroup, np.ndarray]) -> None:
    cams, pts = scene
    if not _well_separated(cams):
        return
    px = cams.project(pts)
    res = solve(px, np.ones(px.shape[:-1]), cams)
    np.testing.assert_allclose(res.points, pts, atol=1e-5)
    np.testing.assert_allclose(cams.project(res.points), px, atol=1e-3)


@settings(max_examples=50, deadline=None)
@given(scene=scenes(), scale=st.floats(0.1, 10.0))
def test_dlt_weights_scale_free(scene: tuple[CameraGroup, np.ndarray], scale: float) -> None:
    """Scaling all weights by one factor changes nothing (only relative confidence counts)."""
    cams, pts = scene
    if not _well_separated(cams):
        return
    px = cams.project(pts)
    norm = cams.undistort_points(px, normalised=True)
    extr = np.stack([c.extrinsics for c in cams])
    w = np.random.default_rng(0).uniform(0.3, 1.0, px.shape[:-1])
    np.testing.assert_allclose(
        dlt(norm, extr, weights=w * scale), dlt(norm, extr, weights=w), atol=1e-7
    )


def test_bad_shapes() -> None:
    cams = ring(3)
    with pytest.raises(InputError, match="need pixels"):
        solve(np.zeros((2, 5, 2)), np.zeros((2, 5)), cams)
    with pytest.raises(InputError, match="min_cameras"):
        solve(np.zeros((3, 5, 2)), np.zeros((3, 5)), cams, min_cameras=1)


def test_confidence_weights_the_views() -> None:
    """A view that is a few pixels off pulls the point less when its confidence is low."""
    cams = ring(3)
    X = motion(5, np.random.default_rng(5))
    px = cams.project(X)
    px[2] += 6.0  # under any exclusion threshold used below
    equal = np.ones(px.shape[:-1])
    low = equal.copy()
    low[2] = 0.35
    err_equal = np.linalg.norm(solve(px, equal, cams).points - X, axis=-1)
    err_low = np.linalg.norm(solve(px, low, cams).points - X, axis=-1)
    assert np.all(err_low < 0.7 * err_equal)


def _views(cams: CameraGroup, px: np.ndarray) -> Views:
    conf = np.ones(px.shape[:-1])
    return Views.of(np.concatenate([px, conf[..., None]], axis=-1), cams, min_confidence=0.3)


def test_a_left_right_swap_in_one_camera_is_undone() -> None:
    """Camera 1 of 4 (facing the person) labels the elbows the wrong way round in 10 frames."""
    cams = ring(4)
    X = motion(30, np.random.default_rng(6))
    px = cams.project(X) + np.random.default_rng(7).normal(0, 1.0, (4, 30, 17, 2))
    le, re = COCO17.index["left_elbow"], COCO17.index["right_elbow"]
    px[1, 5:15, [le, re]] = px[1, 5:15, [re, le]]
    swapped = fix_swaps(_views(cams, px), max_error_px=12.0)
    assert swapped[1, 5:15, [le, re]].all()
    assert swapped.sum() == 2 * 10  # nothing else exchanged
    fixed = relabel(px, swapped)
    np.testing.assert_array_equal(fixed[1, 5:15, le], px[1, 5:15, re])


def test_with_two_cameras_the_camera_whose_labels_jumped_is_exchanged() -> None:
    """Two cameras 90° apart; camera 1 labels the wrists the wrong way round in frames 10-17
    (as Demo_SinglePerson cam02 does the whole body). Exchanging either camera's labels
    reprojects alike; only camera 1's jumped, and only its exchange gives the true points."""
    cams = CameraGroup(list(ring(4))[:2])
    lw, rw = COCO17.index["left_wrist"], COCO17.index["right_wrist"]
    X = motion(30, np.random.default_rng(10))
    X[:, [lw, rw], 0] += [0.3, -0.3]  # arms spread: every swapped frame reprojects badly
    px = cams.project(X) + np.random.default_rng(11).normal(0, 0.5, (2, 30, 17, 2))
    px[1, 10:18, [lw, rw]] = px[1, 10:18, [rw, lw]]
    for order in (cams, CameraGroup(list(cams)[::-1])):  # camera order does not decide
        flipped = 1 if order is cams else 0
        views = px if order is cams else px[::-1]
        swapped = fix_swaps(_views(order, views), max_error_px=12.0)
        assert swapped[flipped, 10:18][:, [lw, rw]].all()
        assert swapped.sum() == 2 * 8  # nothing else exchanged
        tri = solve(relabel(views, swapped), np.ones(views.shape[:-1]), order, max_error_px=12.0)
        assert np.nanmax(np.linalg.norm(tri.points[:, [lw, rw]] - X[:, [lw, rw]], axis=-1)) < 0.03


def test_a_mirrored_stretch_seen_by_two_cameras_is_untangled() -> None:
    """Two cameras agreeing on a swap give a mirrored pair: only continuity can tell."""
    X = motion(40, np.random.default_rng(8))
    lw, rw = COCO17.index["left_wrist"], COCO17.index["right_wrist"]
    bad = X.copy()
    bad[10:18, [lw, rw]] = X[10:18, [rw, lw]]
    crossed = untangle(bad)
    assert crossed[10:18, [lw, rw]].all() and crossed.sum() == 2 * 8
    np.testing.assert_array_equal(relabel(bad[None], crossed[None])[0], X)


def test_gross_outliers_are_solved_again_and_refinement_holds_the_bones() -> None:
    """Two cameras agree on a wrong wrist (reprojection cannot see it): the bone check finds
    it, the other cameras solve it; the take's fit then keeps every bone at one length."""
    rng = np.random.default_rng(9)
    cams = ring(4)
    T = 40
    t = np.linspace(0, 2, T)[:, None, None]
    sway = np.concatenate([0.2 * np.sin(2 * t), 0.1 * np.cos(3 * t), 0 * t], axis=-1)
    X = SKELETON[None] + sway  # a rigid body moving smoothly, as the refinement assumes
    px = cams.project(X) + rng.normal(0, 1.5, (4, T, 17, 2))
    lw = COCO17.index["left_wrist"]
    wrong = X.copy()
    wrong[:, lw] += np.array([0.0, 0.0, 0.25])  # 25 cm off: both views move along it
    px[:2, ::5, lw] = cams.project(wrong)[:2, ::5, lw]
    views = _views(cams, px)
    tri = solve(px, np.ones(px.shape[:-1]), cams, max_error_px=12.0)
    off = np.linalg.norm(tri.points[::5, lw] - X[::5, lw], axis=-1)
    assert np.median(off) > 0.05  # the DLT with exclusion is fooled
    points, _error, used, _mirrored, counts = make_consistent(
        tri.points,
        tri.error,
        used=tri.used,
        views=views,
        max_error_px=12.0,
        max_bone_dev=0.2,
        max_jump=0.5,
    )
    assert counts.suspects >= T // 5
    assert np.nanmax(np.linalg.norm(points[:, lw] - X[:, lw], axis=-1)) < 0.03
    assert not used[:2, ::5, lw].any()  # the two lying cameras are left out
    refined, summary = refine(
        points, np.arange(T) / 30.0, views=views, used=used,
        max_error_px=12.0, smooth_accel_mps2=30.0, bone_tolerance_m=0.01, chunk_frames=30,
    )  # fmt: skip
    print(f"\nrefinement: {summary}")
    assert summary.bone_cv_after < 0.7 * summary.bone_cv_before
    err_before = np.linalg.norm(points - X, axis=-1)
    err_after = np.linalg.norm(refined - X, axis=-1)
    before, after = np.nanmedian(err_before) * 1000, np.nanmedian(err_after) * 1000
    print(f"3D error median {before:.1f} → {after:.1f} mm")
    assert np.nanmedian(err_after) < 0.9 * np.nanmedian(err_before)
