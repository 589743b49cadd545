"""Properties of the shared geometry: rotations, vectors, the body frame and the pinhole camera."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from gesturebank import geometry as G
from gesturebank.errors import InputError
from gesturebank.poses import Pose3D
from gesturebank.skeletons import COCO17
from tests.test_imports import ROOT, import_graph

angles = arrays(np.float64, st.integers(1, 20), elements=st.floats(-10, 10))
axes = st.integers(0, 2)
vectors = arrays(np.float64, 3, elements=st.floats(-2, 2))
rotvecs = arrays(np.float64, 3, elements=st.floats(-3, 3))


def rotation(rotvec: np.ndarray) -> np.ndarray:
    return Rotation.from_rotvec(rotvec).as_matrix()


# ------------------------------------------------------------------------------- rotations


@settings(max_examples=100, deadline=None)
@given(t=angles, axis=axes)
def test_axis_rotations_are_proper_rotations(t: np.ndarray, axis: int) -> None:
    r = G.axis_rotations(axis, t)
    assert r.shape == (len(t), 3, 3)
    np.testing.assert_allclose(
        r @ r.transpose(0, 2, 1), np.broadcast_to(np.eye(3), r.shape), atol=1e-12
    )
    np.testing.assert_allclose(np.linalg.det(r), 1.0, atol=1e-12)
    np.testing.assert_allclose(r[:, :, axis], np.broadcast_to(np.eye(3)[axis], (len(t), 3)), atol=0)


@settings(max_examples=100, deadline=None)
@given(t=angles, axis=axes, data=st.data())
def test_axis_rotations_compose_and_invert(t: np.ndarray, axis: int, data: st.DataObject) -> None:
    u = data.draw(arrays(np.float64, len(t), elements=st.floats(-10, 10)))
    a, b = G.axis_rotations(axis, t), G.axis_rotations(axis, u)
    np.testing.assert_allclose(a @ b, G.axis_rotations(axis, t + u), atol=1e-12)
    np.testing.assert_allclose(G.axis_rotations(axis, -t), a.transpose(0, 2, 1), atol=1e-12)


@pytest.mark.parametrize(("axis", "start", "end"), [(0, 1, 2), (1, 2, 0), (2, 0, 1)])
def test_axis_rotations_turn_counterclockwise(axis: int, start: int, end: int) -> None:
    """Right-handed: a quarter turn about x takes y to z, about y takes z to x, about z x to y."""
    r = G.axis_rotations(axis, np.array([np.pi / 2]))[0]
    np.testing.assert_allclose(r @ np.eye(3)[start], np.eye(3)[end], atol=1e-15)


# ------------------------------------------------------------------------------- vectors


@settings(max_examples=100, deadline=None)
@given(
    a=arrays(np.float64, (5, 3), elements=st.floats(-5, 5)),
    b=arrays(np.float64, (5, 3), elements=st.floats(-5, 5)),
)
def test_cross_dot_and_unit_along_either_axis(a: np.ndarray, b: np.ndarray) -> None:
    np.testing.assert_allclose(G.cross(a, b), np.cross(a, b), atol=1e-12)
    np.testing.assert_allclose(G.cross(a.T, b.T, axis=0), np.cross(a, b).T, atol=1e-12)
    np.testing.assert_allclose(G.dot(a, b), np.einsum("ij,ij->i", a, b), atol=1e-12)
    long = np.linalg.norm(a, axis=1) > 1e-3
    u = G.unit(a[long])
    np.testing.assert_allclose(np.linalg.norm(u, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(G.unit(a[long].T, axis=0), u.T, atol=1e-15)


# ------------------------------------------------------------------------------- the body frame


def body_frame(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`G.body_frame` of (4, 3) left shoulder, right shoulder, left hip, right hip."""
    return G.body_frame(pts[0], pts[1], left_hip=pts[2], right_hip=pts[3])


def torso_points(data: st.DataObject) -> np.ndarray:
    """(4, 3) left shoulder, right shoulder, left hip, right hip, not degenerate."""
    pts = data.draw(arrays(np.float64, (4, 3), elements=st.floats(-1, 1)))
    across, up = G.torso_vectors(pts[0], pts[1], left_hip=pts[2], right_hip=pts[3])
    assume(np.linalg.norm(up) > 0.1 and np.linalg.norm(across) > 0.1)
    assume(np.linalg.norm(np.cross(G.unit(across), G.unit(up))) > 0.1)  # not parallel
    return pts


@settings(max_examples=200, deadline=None)
@given(data=st.data(), rotvec=rotvecs, shift=vectors, scale=st.floats(0.01, 100))
def test_body_frame_moves_with_the_body(
    data: st.DataObject, rotvec: np.ndarray, shift: np.ndarray, scale: float
) -> None:
    """Turning, moving and scaling the body turns its frame the same way, and nothing more."""
    pts = torso_points(data)
    r = rotation(rotvec)
    frame = np.stack(body_frame(pts))  # rows forward, left, up
    moved = np.stack(body_frame(scale * pts @ r.T + shift))
    np.testing.assert_allclose(moved, frame @ r.T, atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(data=st.data())
def test_body_frame_is_right_handed_and_orthonormal(data: st.DataObject) -> None:
    pts = torso_points(data)
    frame = np.stack(body_frame(pts))
    np.testing.assert_allclose(frame @ frame.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(frame) == pytest.approx(1.0, abs=1e-12)
    ls, rs, lh, rh = pts
    assert np.dot(frame[2], (ls + rs - lh - rh) / 2) > 0  # up: hips → shoulders
    assert np.dot(frame[1], ls - rs) > 0  # left: towards the left shoulder


def test_body_frame_of_an_upright_person() -> None:
    """Standing along z, the left shoulder at +y: forward is +x (chest), in per-frame arrays
    either component-last (T, 3) or component-first (3, T)."""
    ls, rs = np.array([[0.0, 0.2, 1.5]]), np.array([[0.0, -0.2, 1.5]])
    lh, rh = np.array([[0.05, 0.1, 1.0]]), np.array([[0.05, -0.1, 1.0]])
    fwd, left, up = G.body_frame(ls, rs, left_hip=lh, right_hip=rh)
    tilt = np.arctan2(0.05, 0.5)
    np.testing.assert_allclose(fwd, [[np.cos(tilt), 0.0, np.sin(tilt)]], atol=1e-12)
    np.testing.assert_allclose(left, [[0.0, 1.0, 0.0]], atol=1e-12)
    first = G.body_frame(ls.T, rs.T, left_hip=lh.T, right_hip=rh.T, axis=0)
    np.testing.assert_allclose(np.stack(first), np.stack([fwd.T, left.T, up.T]), atol=0)


# ------------------------------------------------------------------------------- the camera


@st.composite
def cameras(draw: st.DrawFn) -> G.Camera:
    f = draw(st.floats(300, 3000))
    cx, cy = draw(st.floats(300, 1000)), draw(st.floats(200, 700))
    dist = draw(arrays(np.float64, 5, elements=st.floats(-0.02, 0.02)))
    return G.Camera(
        "cam",
        (1920, 1080),
        np.array([[f, 0.0, cx], [0.0, f * draw(st.floats(0.9, 1.1)), cy], [0.0, 0.0, 1.0]]),
        dist,
        rotation(draw(rotvecs)),
        draw(vectors),
    )


def in_view(camera: G.Camera, data: st.DataObject, n: int = 6) -> np.ndarray:
    """(n, 3) world points in front of `camera`, within ±0.5 of its axis per unit depth."""
    xy = data.draw(arrays(np.float64, (n, 2), elements=st.floats(-0.5, 0.5)))
    z = data.draw(arrays(np.float64, (n, 1), elements=st.floats(0.5, 10)))
    local = np.concatenate([xy * z, z], axis=1)
    return (local - camera.t) @ camera.R  # R^T (x - t)


@settings(max_examples=100, deadline=None)
@given(camera=cameras(), data=st.data())
def test_a_pixel_back_projects_along_the_ray_of_its_point(
    camera: G.Camera, data: st.DataObject
) -> None:
    points = in_view(camera, data)
    pixels = camera.project(points)
    ray = np.concatenate(
        [camera.undistort_points(pixels, normalised=True), np.ones((len(points), 1))], 1
    )
    direction = ray @ camera.R  # camera → world: R^T ray
    to_point = points - camera.center
    np.testing.assert_allclose(G.unit(direction), G.unit(to_point), atol=1e-7)
    # and the ray's point at the right depth projects to the same pixel
    depth = (points @ camera.R.T + camera.t)[:, 2:]
    np.testing.assert_allclose(camera.project(camera.center + depth * direction), pixels, atol=1e-6)


@settings(max_examples=100, deadline=None)
@given(camera=cameras(), data=st.data(), rotvec=rotvecs, shift=vectors)
def test_projection_is_unchanged_by_moving_camera_and_points_together(
    camera: G.Camera, data: st.DataObject, rotvec: np.ndarray, shift: np.ndarray
) -> None:
    points = in_view(camera, data)
    q = rotation(rotvec)
    moved = G.Camera(
        camera.name,
        camera.size,
        camera.K,
        camera.dist,
        camera.R @ q.T,
        camera.t - camera.R @ q.T @ shift,
    )
    np.testing.assert_allclose(
        moved.project(points @ q.T + shift), camera.project(points), atol=1e-6
    )
    np.testing.assert_allclose(moved.center, q @ camera.center + shift, atol=1e-9)


def test_points_behind_the_camera_do_not_project() -> None:
    camera = G.Camera(
        "c", (640, 480), np.diag([500.0, 500.0, 1.0]), np.zeros(0), np.eye(3), np.zeros(3)
    )
    px = camera.project(np.array([[0.1, 0.2, 2.0], [0.1, 0.2, -2.0]]))
    np.testing.assert_allclose(px[0], [25.0, 50.0])
    assert np.isnan(px[1]).all()


# ------------------------------------------------------------------------- cameras in a Pose3D


def test_a_pose3d_keeps_its_cameras_through_its_arrays() -> None:
    cams = G.CameraGroup(
        [
            G.Camera(
                "a", (640, 480), np.diag([500.0, 500.0, 1.0]), np.zeros(5), np.eye(3), np.zeros(3)
            ),
            G.Camera(
                "b",
                (640, 480),
                np.diag([600.0, 600.0, 1.0]),
                np.zeros(4),
                rotation(np.array([0.0, 0.3, 0.0])),
                np.ones(3),
            ),
        ]
    )
    joints = np.random.default_rng(0).normal(size=(4, len(COCO17), 3))
    pose = Pose3D(joints, np.ones((4, len(COCO17))), np.arange(4) / 30, frame="world", cameras=cams)
    back = Pose3D.from_arrays(pose.to_arrays("pose3d_"), "pose3d_")
    assert back.cameras is not None and back.cameras.names == ["a", "b"]
    np.testing.assert_allclose(back.cameras.project(joints), cams.project(joints), atol=1e-9)
    assert back.meta == {}
    assert (
        Pose3D.from_arrays(Pose3D(joints, np.ones((4, 17)), np.arange(4.0)).to_arrays()).cameras
        is None
    )
    broken = {**pose.to_arrays(), "meta_calibration": np.array("[{")}
    with pytest.raises(InputError, match="stored cameras"):
        Pose3D.from_arrays(broken)
    with pytest.raises(InputError, match="calibration"):
        Pose3D(joints, np.ones((4, 17)), np.arange(4.0), meta={"calibration": "[]"})


def test_geometry_sits_on_the_ground_floor_and_mocap_below_robot() -> None:
    graph = import_graph(ROOT)
    assert graph["gesturebank.geometry"] <= {"gesturebank.errors"}
    mocap = [m for m in graph if m.startswith("gesturebank.mocap")]
    assert mocap and not any(t.startswith("gesturebank.robot") for m in mocap for t in graph[m])
