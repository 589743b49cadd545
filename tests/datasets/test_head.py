"""The head of a clip from the face or the body (issue 40): the face where it was found and the
torso seen, the body's face keypoints elsewhere (as they are), the source of every frame; the
face's axes put into a lifter's frame or a calibrated camera's world."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gesturebank.datasets.head import BODY, FACE, FaceHead, in_pose_frame, mix_head, rig_head
from gesturebank.geometry import Camera
from gesturebank.poses import Pose3D
from gesturebank.robot import pepper
from gesturebank.robot.retarget import head_from_axes, head_roll, pepper_angles
from tests.robot.test_head_roll import _joints

P, Y = pepper.INDEX["HeadPitch"], pepper.INDEX["HeadYaw"]


def _pose(joints: np.ndarray, frame: str = "camera") -> Pose3D:
    t = len(joints)
    return Pose3D(
        joints.astype(np.float32), np.ones((t, 17), np.float32), np.arange(t) / 30.0, frame=frame
    )


def _scene(n: int = 40) -> tuple[Pose3D, np.ndarray, np.ndarray]:
    """A head turning (yaw 0 → 0.6, pitch 0.2, roll −0.1) on a still torso: its pose, and the
    head's true axes (T, 3, 3) in the pose's coordinates."""
    turns = [(y, 0.2, -0.1) for y in np.linspace(0.0, 0.6, n)]
    joints = np.stack([_joints(*t) for t in turns])
    axes = np.stack([Rotation.from_euler("ZYX", t).as_matrix() for t in turns])
    return _pose(joints), joints, axes


def test_the_face_is_used_where_found_and_the_body_elsewhere_as_it_is() -> None:
    pose, joints, axes = _scene()
    n = len(joints)
    raw = pepper_angles(joints)
    raw[:, P] += 0.35  # the body's face points: a pitch bias
    roll = head_roll(joints)
    face_ok = np.arange(n) < 30  # the face turns away from the camera at frame 30
    got, got_roll, source = mix_head(
        pose3d=pose, raw=raw, roll=roll, body_ok=np.ones(n, bool), torso_ok=np.ones(n, bool),
        face_axes=axes, face_ok=face_ok,
    )  # fmt: skip
    assert source.dtype == np.int8
    np.testing.assert_array_equal(source, np.where(face_ok, FACE, BODY))
    truth = pepper_angles(joints)
    np.testing.assert_allclose(got[:30][:, [P, Y]], truth[:30][:, [P, Y]], atol=1e-4)
    np.testing.assert_allclose(got[30:][:, [P, Y]], raw[30:][:, [P, Y]])  # the body's, biased
    np.testing.assert_allclose(got_roll, roll, atol=1e-4)
    np.testing.assert_array_equal(got[:, 2:], raw[:, 2:])  # the arms untouched


def test_no_torso_takes_the_body_and_unknown_stays_unknown() -> None:
    pose, joints, axes = _scene()
    n = len(joints)
    raw = pepper_angles(joints)
    raw[:, P] += 0.35
    face_ok = np.arange(n) < 9
    body_ok = np.arange(n) < n - 5
    torso_ok = np.ones(n, bool)
    torso_ok[3] = False  # no torso: the face's head cannot be put against it
    got, got_roll, source = mix_head(
        pose3d=pose, raw=raw, roll=head_roll(joints), body_ok=body_ok, torso_ok=torso_ok,
        face_axes=axes, face_ok=face_ok,
    )  # fmt: skip
    assert source[3] == BODY and source[0] == FACE and (source[-5:] == 0).all()
    assert got[3, P] == raw[3, P]
    np.testing.assert_allclose(got[9:-5, P], raw[9:-5, P])
    assert np.isnan(got[-5:, [P, Y]]).all() and np.isnan(got_roll[-5:]).all()


def test_without_a_face_the_body_is_the_head() -> None:
    pose, joints, _ = _scene(8)
    raw = pepper_angles(joints)
    body_ok = np.arange(8) % 2 == 0
    got, _, source = mix_head(
        pose3d=pose, raw=raw, roll=head_roll(joints), body_ok=body_ok,
        torso_ok=np.ones(8, bool), face_axes=None, face_ok=np.zeros(8, bool),
    )  # fmt: skip
    np.testing.assert_array_equal(got, raw)
    np.testing.assert_array_equal(source, np.where(body_ok, BODY, 0))


def test_camera_axes_go_into_the_lifters_frame_and_a_calibrated_world() -> None:
    rot = Rotation.from_euler("xyz", [10, -40, 5], degrees=True).as_matrix()[None]
    joints = np.zeros((1, 17, 3))
    flipped = in_pose_frame(rot, pose3d=_pose(joints, "image-ortho"), camera=None)
    assert flipped is not None
    np.testing.assert_allclose(flipped[0], np.diag([1.0, -1.0, -1.0]) @ rot[0])
    np.testing.assert_allclose(in_pose_frame(rot, pose3d=_pose(joints), camera=None)[0], rot[0])
    world_to_cam = Rotation.from_euler("y", 70, degrees=True).as_matrix()
    K = np.array([[800.0, 0, 640], [0, 800.0, 360], [0, 0, 1]])
    cam = Camera("c", (1280, 720), K, np.zeros(0), world_to_cam, np.zeros(3))
    world = in_pose_frame(rot, pose3d=_pose(joints, "world"), camera=cam)
    assert world is not None
    np.testing.assert_allclose(world_to_cam @ world[0], rot[0], atol=1e-12)
    assert in_pose_frame(rot, pose3d=_pose(joints, "nobody-knows"), camera=None) is None
    assert pytest.approx(np.linalg.det(world[0])) == 1.0


def test_a_fast_small_nod_survives_the_face_models_rate_and_the_processing() -> None:
    """Seed 002's head motion is fast and small: a 2.5 Hz nod of ±6° measured by the face model
    on every 2nd frame of a 30 fps video (speech.mouth_rate_hz 15), spread to every frame and
    processed as the build does (100 Hz, 4 Hz low-pass) keeps ≥ 85 % of its swing."""
    from gesturebank.config import Config
    from gesturebank.datasets.process import process_angles
    from gesturebank.extract.head_pose import spread_heads

    fps, seconds, amp, hz = 30.0, 4.0, np.deg2rad(6.0), 2.5
    ts = np.arange(0, seconds, 1 / fps)
    pitch = amp * np.sin(2 * np.pi * hz * ts)
    rows = np.arange(0, len(ts), 2)
    axes = np.stack([Rotation.from_euler("Y", p).as_matrix() for p in pitch[rows]])[:, None]
    spread, _, _ = spread_heads(
        rows,
        axes,
        centre=np.zeros((len(rows), 1, 2)),
        residual=np.zeros((len(rows), 1)),
        n_frames=len(ts),
    )
    joints = np.stack([_joints(0.0, 0.0, 0.0)] * len(ts))
    raw = pepper_angles(joints)
    raw[:, [P, Y]] = head_from_axes(joints, spread[:, 0])[:, :2]
    config = Config()
    clock = np.arange(ts[0], ts[-1], 0.01)
    processed = process_angles(
        raw=raw, timestamps=ts, clock=clock, processing=config.processing,
        retarget=config.retarget, profile=pepper.load_profile(config.robot.profile),
    )  # fmt: skip
    inner = (clock > 0.5) & (clock < seconds - 0.5)
    swing = np.ptp(processed.angles[inner, P])
    assert swing >= 0.85 * 2 * amp


def _camera(name: str, rotvec: tuple[float, float, float]) -> Camera:
    k = np.array([[1000.0, 0, 640], [0, 1000.0, 360], [0, 0, 1]])
    rotation = Rotation.from_rotvec(rotvec).as_matrix()
    return Camera(name, (1280, 720), k, np.zeros(5), rotation, np.array([0.0, 0.0, 3.0]))


def test_a_rigs_face_heads_are_averaged_on_the_reference_clock_in_its_axes() -> None:
    """`rig_head`: two calibrated cameras, the second's clock 0.1 s ahead; each sees the head
    turned 4° off the truth, the other way; combined in the reference camera's axes they give
    the truth, within 1°. A frame only one camera saw (or fitted within the limit) takes that
    camera's head; none: NaN."""
    n = 12
    world = Rotation.from_euler("ZYX", np.stack([np.linspace(0, 0.5, n), [0.2] * n, [0.0] * n],
                                                axis=1)).as_matrix()  # fmt: skip
    cams = [_camera("a", (0.0, 0.4, 0.0)), _camera("b", (0.1, -0.5, 0.0))]
    off = Rotation.from_rotvec([0.0, np.radians(4.0), 0.0]).as_matrix()
    seen = [c.R @ r @ world for c, r in zip(cams, (off, off.T), strict=True)]  # camera axes
    times = [np.arange(n) / 10.0, np.arange(n) / 10.0 + 0.1]
    heads = [FaceHead(seen[0], np.full(n, 0.01)), FaceHead(seen[1], np.full(n, 0.02))]
    heads[0].axes[3] = np.nan  # camera a lost the face on frame 3
    heads[1].residual[5] = 0.5  # camera b's fit on frame 5 is past the limit: not averaged
    fused = rig_head(heads, times=times, offsets_s=[0.0, 0.1], cameras=cams, reference=0,
                     max_residual=0.1)  # fmt: skip
    assert fused is not None
    truth = cams[0].R @ world
    both = [k for k in range(n) if k not in (3, 5)]
    angle = Rotation.from_matrix(np.swapaxes(fused.axes[both], 1, 2) @ truth[both]).magnitude()
    # the two cameras' 4° errors cancel, but for each camera counting its own depth direction
    # less (`RIG_DEPTH_WEIGHT`): within 1° (the plain average: 0.3°)
    assert np.degrees(angle).max() < 1.0
    alone = cams[0].R @ cams[1].R.T @ seen[1][3]
    assert np.allclose(fused.axes[3], alone, atol=1e-9)
    assert np.allclose(fused.residual[both], 0.02)
    assert np.allclose(fused.axes[5], seen[0][5], atol=1e-9)  # camera a's alone
    assert fused.residual[5] == pytest.approx(0.01)
    # the second camera's clock 0.6 s ahead: the reference's first 6 frames are before its
    # first (more than half a frame), the rest are its frames 0-5
    late = rig_head([None, heads[1]], times=times, offsets_s=[0.0, -0.5], cameras=cams,
                    reference=0, max_residual=1.0)  # fmt: skip
    assert late is not None
    assert np.isnan(late.axes[:6]).all()
    assert np.allclose(late.axes[6:], cams[0].R @ cams[1].R.T @ seen[1][:6], atol=1e-9)
    assert rig_head([None, None], times=times, offsets_s=[0.0, 0.1], cameras=cams,
                    reference=0, max_residual=1.0) is None  # fmt: skip


def test_a_rigs_cameras_count_less_along_their_own_depth() -> None:
    """`rig_head`: two cameras 90° apart; the head faces camera a, which reads it right, and
    camera b reads its direction 10° wrong along b's own optical axis (the face model's weak
    direction). The rotation nearest the two readings' sum keeps half of b's error; counting
    each camera's depth direction less (RIG_DEPTH_WEIGHT) keeps under half of that."""
    n = 3
    cams = [_camera("a", (0.0, np.pi / 4, 0.0)), _camera("b", (0.0, -np.pi / 4, 0.0))]
    forward = -cams[0].R[2]  # facing camera a (its optical axis, in the world, reversed)
    up = np.array([0.0, -1.0, 0.0])  # the world's y is down
    head = np.stack([forward, np.cross(up, forward), up], axis=1)  # columns forward, left, up
    turn_axis = np.cross(forward, cams[1].R[2])  # b's depth direction, seen from the head
    wrong = Rotation.from_rotvec(np.radians(10.0) * turn_axis / np.linalg.norm(turn_axis))
    seen = [np.repeat((cams[0].R @ head)[None], n, axis=0),
            np.repeat((cams[1].R @ wrong.as_matrix() @ head)[None], n, axis=0)]  # fmt: skip
    heads = [FaceHead(axes, np.full(n, 0.01)) for axes in seen]
    times = [np.arange(n) / 10.0] * 2
    fused = rig_head(heads, times=times, offsets_s=[0.0, 0.0], cameras=cams, reference=0,
                     max_residual=0.1)  # fmt: skip
    assert fused is not None
    truth = cams[0].R @ head

    def off(axes: np.ndarray) -> float:  # degrees between the forward directions
        return float(np.degrees(np.arccos(np.clip(axes[:, 0] @ truth[:, 0], -1.0, 1.0))))

    mine = [cams[0].R @ c.R.T @ axes[0] for c, axes in zip(cams, seen, strict=True)]
    u, _, vt = np.linalg.svd(mine[0] + mine[1])
    plain = u @ vt  # the rotation nearest the two readings' sum (the plain average)
    assert off(mine[0]) < 1e-6 and off(mine[1]) == pytest.approx(10.0, abs=0.01)
    assert 4.0 < off(plain) < 6.0
    assert off(fused.axes[0]) < 0.5 * off(plain)
