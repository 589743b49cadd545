"""Cameras: projection against OpenCV, undistortion round trips, TOML and Qualisys files."""

from __future__ import annotations

import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gesturebank.camera_files import Camera, CameraGroup, load_cameras, read_qca, save_cameras
from gesturebank.errors import CalibrationError


def fl(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


@st.composite
def cameras(draw: st.DrawFn, name: str = "cam") -> Camera:
    """A random but plausible camera: focal 300–3000 px, mild distortion, any orientation."""
    w = draw(st.integers(320, 2000))
    h = draw(st.integers(240, 2000))
    f = draw(fl(300, 3000))
    aspect = draw(fl(0.95, 1.05))
    cx = draw(fl(0.4, 0.6)) * w
    cy = draw(fl(0.4, 0.6)) * h
    dist = [
        draw(fl(-0.2, 0.2)),
        draw(fl(-0.1, 0.1)),
        draw(fl(-0.003, 0.003)),
        draw(fl(-0.003, 0.003)),
        draw(fl(-0.02, 0.02)),
    ]
    rvec: np.ndarray = np.array(draw(st.lists(fl(-3, 3), min_size=3, max_size=3)))
    t: np.ndarray = np.array(draw(st.lists(fl(-5, 5), min_size=3, max_size=3)))
    K = np.array([[f, 0, cx], [0, f * aspect, cy], [0, 0, 1]])
    return Camera(name=name, size=(w, h), K=K, dist=np.array(dist), R=rvec, t=t)


def points_in_view(cam: Camera, rng: np.random.Generator, n: int = 50) -> np.ndarray:
    """(n, 3) world points inside the central part of the camera's view, 1–8 m away."""
    x = rng.uniform(-0.5, 0.5, n)
    y = rng.uniform(-0.5, 0.5, n)
    z = rng.uniform(1, 8, n)
    cam_pts = np.stack([x * z, y * z, z], axis=1)
    return (cam_pts - cam.t) @ cam.R  # camera → world: R^T (p − t)


@settings(max_examples=60, deadline=None)
@given(cam=cameras(), seed=st.integers(0, 2**32 - 1))
def test_project_matches_opencv(cam: Camera, seed: int) -> None:
    pts = points_in_view(cam, np.random.default_rng(seed))
    ours = cam.project(pts)
    theirs, _ = cv2.projectPoints(pts, cam.rvec, cam.t, cam.K, cam.dist)
    np.testing.assert_allclose(ours, theirs.reshape(-1, 2), rtol=1e-6, atol=1e-3)  # millipixels


@settings(max_examples=60, deadline=None)
@given(cam=cameras(), seed=st.integers(0, 2**32 - 1))
def test_undistort_inverts_distortion(cam: Camera, seed: int) -> None:
    pts = points_in_view(cam, np.random.default_rng(seed))
    cam_pts = cam.to_camera(pts)
    ideal = cam_pts[:, :2] / cam_pts[:, 2:]  # pinhole, no lens
    np.testing.assert_allclose(
        cam.undistort_points(cam.project(pts), normalised=True), ideal, atol=1e-7
    )
    ideal_px = ideal @ cam.K[:2, :2].T + cam.K[:2, 2]
    np.testing.assert_allclose(cam.undistort_points(cam.project(pts)), ideal_px, atol=1e-4)


def test_missing_and_hidden_points_project_to_nan() -> None:
    cam = Camera("c", (640, 480), np.array([[500, 0, 320], [0, 500, 240], [0, 0, 1.0]]),
                 np.zeros(5), np.eye(3), np.zeros(3))  # fmt: skip
    px = cam.project(np.array([[0, 0, 2.0], [0, 0, -2.0], [np.nan, 0, 1]]))
    np.testing.assert_allclose(px[0], [320, 240])
    assert np.isnan(px[1:]).all()
    und = cam.undistort_points(np.array([[np.nan, np.nan], [320, 240]]))
    assert np.isnan(und[0]).all()
    np.testing.assert_allclose(und[1], [320, 240])


@settings(max_examples=40, deadline=None)
@given(cams=st.lists(cameras(), min_size=1, max_size=5))
def test_toml_round_trip(tmp_path_factory: pytest.TempPathFactory, cams: list[Camera]) -> None:
    group = CameraGroup(
        [Camera(f"cam{i:02d}", c.size, c.K, c.dist, c.R, c.t) for i, c in enumerate(cams)]
    )
    path = tmp_path_factory.mktemp("toml") / "calibration.toml"
    save_cameras(group, path)
    back = load_cameras(path)
    assert back.names == group.names
    for a, b in zip(group, back, strict=True):
        assert a.size == b.size
        np.testing.assert_allclose(b.K, a.K)
        np.testing.assert_allclose(b.dist, a.dist)
        np.testing.assert_allclose(b.R, a.R, atol=1e-9)
        np.testing.assert_allclose(b.t, a.t)
    # The layout is Pose2Sim's: one table per camera plus metadata.
    data = tomllib.loads(path.read_text())
    assert set(data) == {*group.names, "metadata"}
    assert set(data["cam00"]) >= {"name", "size", "matrix", "distortions", "rotation",
                                  "translation", "fisheye"}  # fmt: skip


def test_reads_sports2d_toml(samples: Path) -> None:
    path = samples / "sports2d/Demo/Calib_demo.toml"
    raw = tomllib.loads(path.read_text())["demo"]
    (cam,) = load_cameras(path)
    assert cam.name == "demo" and cam.size == tuple(raw["size"])
    np.testing.assert_allclose(cam.K, raw["matrix"])
    np.testing.assert_allclose(cam.rvec, raw["rotation"], atol=1e-9)
    np.testing.assert_allclose(cam.t, raw["translation"])


def test_reads_qualisys_demo(samples: Path) -> None:
    path = samples / "pose2sim/Demo_SinglePerson/calibration/Calib.qca.txt"
    group = read_qca(path)
    nodes = list(ET.parse(path).getroot().iter("camera"))
    assert group.names == [n.get("serial") for n in nodes] == ["cam01", "cam02", "cam03", "cam04"]
    for cam, node in zip(group, nodes, strict=True):
        tr, intr = node.find("transform"), node.find("intrinsic")
        assert tr is not None and intr is not None
        xyz_m = np.array([float(tr.get(k, "nan")) for k in "xyz"]) / 1000
        np.testing.assert_allclose(cam.center, xyz_m, atol=1e-9)
        assert cam.K[0, 0] == pytest.approx(float(intr.get("focalLengthU", "nan")) / 64)
        assert cam.size == (1088, 1920)
    # All four cameras look at one shared spot (the capture volume), which each sees near
    # its image centre: the point closest to all four optical axes projects inside every image.
    centers = np.stack([c.center for c in group])
    axes = np.stack([c.R[2] for c in group])  # optical axis in world coordinates
    A = sum(np.eye(3) - np.outer(a, a) for a in axes)
    b = sum((np.eye(3) - np.outer(a, a)) @ c for a, c in zip(axes, centers, strict=True))
    spot = np.linalg.solve(A, b)
    for cam in group:
        u, v = cam.project(spot)
        assert 0 < u < cam.size[0] and 0 < v < cam.size[1]
        assert cam.to_camera(spot)[2] > 1.0  # in front, more than a metre away


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("[a\nsize = 1", "not valid TOML"),
        ("[metadata]\nerror = 0.0\n", "no camera tables"),
        ('[c]\nsize = [10, 10]\nmatrix = [[1,0,0],[0,1,0],[0,0,1]]\nrotation = [0,0,0]\n',
         "missing translation"),
        ('[c]\nsize = [10, 10]\nmatrix = [[1,0,0],[0,1,0],[0,0,1]]\nrotation = [0,0,0]\n'
         'translation = [0,0,0]\nfisheye = true\n', "fisheye"),
        ('[c]\nsize = [10, 10]\nmatrix = [[1,0],[0,1]]\nrotation = [0,0,0]\n'
         'translation = [0,0,0]\n', "matrix must be"),
        ('[c]\nsize = [10, 10]\nmatrix = [[1,0,0],[0,1,0],[0,0,1]]\nrotation = [0,0,0]\n'
         'translation = [0,0,0]\ndistortions = [0.1, 0.2, 0.3]\n', "distortions"),
    ],
)  # fmt: skip
def test_bad_toml_is_one_line_calibration_error(tmp_path: Path, text: str, problem: str) -> None:
    path = tmp_path / "calibration.toml"
    path.write_text(text)
    with pytest.raises(CalibrationError, match=problem) as info:
        load_cameras(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_bad_files(tmp_path: Path) -> None:
    with pytest.raises(CalibrationError, match="not found"):
        load_cameras(tmp_path / "nope.toml")
    with pytest.raises(CalibrationError, match="unknown calibration format"):
        load_cameras(tmp_path / "calib.yaml")
    bad = tmp_path / "Calib.qca.txt"
    bad.write_text("<calibration><cameras><camera serial='x'/></cameras></calibration>")
    with pytest.raises(CalibrationError, match=r"Calib.qca.txt: camera 'x'"):
        load_cameras(bad)
    bad.write_text("not xml at all")
    with pytest.raises(CalibrationError, match="not a readable Qualisys XML"):
        load_cameras(bad)


def test_rejects_non_rotation() -> None:
    K = np.diag([100.0, 100.0, 1.0])
    with pytest.raises(CalibrationError, match="reflection"):
        Camera("c", (10, 10), K, np.zeros(4), np.diag([1.0, 1.0, -1.0]), np.zeros(3))
    with pytest.raises(CalibrationError, match="not a rotation"):
        Camera("c", (10, 10), K, np.zeros(4), np.eye(3) * 2, np.zeros(3))
    with pytest.raises(CalibrationError, match="names repeat"):
        c = Camera("c", (10, 10), K, np.zeros(4), np.eye(3), np.zeros(3))
        CameraGroup([c, c])
