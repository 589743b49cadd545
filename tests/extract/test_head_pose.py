"""The head's pose from the face mesh (issue 40): the rigid fit and the reference face by
geometry (a known rotation, scale and shift come back), the face seen off the optical axis, the
head between sampled frames, and the real face landmark model on the face photo the renderer
paints (scikit-image's astronaut) turned in the image plane and mirrored."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from gesturebank.config import SpeechConfig
from gesturebank.errors import InputError
from gesturebank.extract import head_pose, mouth
from gesturebank.extract.detectors.blazepose import Roi
from gesturebank.skeletons import COCO17


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**31), scale=st.floats(0.05, 50.0))
def test_rigid_fit_returns_a_known_rotation_scale_and_shift(seed: int, scale: float) -> None:
    rng = np.random.default_rng(seed)
    source = rng.normal(size=(30, 3))
    rot = Rotation.random(random_state=rng).as_matrix()
    shift = rng.normal(0, 100, 3)
    r, s, t, rms = head_pose.rigid_fit(source, scale * source @ rot.T + shift)
    np.testing.assert_allclose(r, rot, atol=1e-6)
    assert s == pytest.approx(scale, rel=1e-6)
    np.testing.assert_allclose(t, shift, atol=1e-6 * max(1.0, scale))
    assert rms == pytest.approx(0.0, abs=1e-6 * scale)


def test_rigid_fit_of_a_mirror_image_is_still_a_rotation() -> None:
    source = np.random.default_rng(0).normal(size=(20, 3))
    r, _, _, rms = head_pose.rigid_fit(source, source * [-1.0, 1.0, 1.0])
    assert np.linalg.det(r) == pytest.approx(1.0) and rms > 0.1


@settings(max_examples=40, deadline=None)
@given(
    yaw=st.floats(-1.2, 1.2), pitch=st.floats(-0.8, 0.8), roll=st.floats(-0.8, 0.8),
    seed=st.integers(0, 2**31),
)  # fmt: skip
def test_a_turned_reference_face_gives_its_turn(
    yaw: float, pitch: float, roll: float, seed: int
) -> None:
    """The reference face turned by R (in its own axes), scaled and shifted, as a mesh would
    come: the head's axes are R times the reference's head axes, the fit exact."""
    rng = np.random.default_rng(seed)
    ref = head_pose.reference_face()
    rot = Rotation.from_euler("YXZ", [yaw, pitch, roll]).as_matrix()
    mesh = rng.uniform(0.2, 5.0) * ref @ rot.T + rng.normal(0, 300, 3)
    fit = head_pose.fit_head(mesh)
    np.testing.assert_allclose(fit.axes, rot @ head_pose.HEAD_IN_REFERENCE, atol=1e-9)
    assert fit.residual == pytest.approx(0.0, abs=1e-9)


def test_the_reference_face_looks_at_the_camera_and_its_left_is_the_images_right() -> None:
    ref = head_pose.reference_face()
    assert ref.shape == (head_pose.N_POINTS, 3)
    forward, left, up = head_pose.HEAD_IN_REFERENCE.T
    assert np.linalg.det(head_pose.HEAD_IN_REFERENCE) == pytest.approx(1.0)
    nose_tip, eyes = ref[1], (ref[33] + ref[263]) / 2
    assert (nose_tip - eyes) @ forward > 0  # the nose stands out towards the camera
    assert (ref[263] - ref[33]) @ left > 0  # 263 is the person's left eye's outer corner
    assert (ref[head_pose.FOREHEAD] - ref[head_pose.CHIN]) @ up > 0
    keep = head_pose.stable_points()
    assert 150 < len(keep) < 400 and 13 not in keep and 14 not in keep  # no lips


def test_bad_meshes_are_refused() -> None:
    with pytest.raises(InputError, match="468, 3"):
        head_pose.fit_head(np.zeros((468, 2)))


def test_a_face_on_the_optical_axis_is_unchanged_and_one_off_it_is_turned_onto_its_ray() -> None:
    focal, principal = np.array([800.0, 800.0]), np.array([640.0, 360.0])
    facing = head_pose.HEAD_IN_REFERENCE  # weak perspective: facing straight back along the ray
    on_axis = head_pose.on_ray(facing, principal, focal=focal, principal=principal)
    np.testing.assert_allclose(on_axis, facing, atol=1e-12)
    centre = np.array([1240.0, 60.0])
    got = head_pose.on_ray(facing, centre, focal=focal, principal=principal)
    ray = np.array([(centre[0] - 640) / 800, (centre[1] - 360) / 800, 1.0])
    np.testing.assert_allclose(got[:, 0], -ray / np.linalg.norm(ray), atol=1e-12)
    assert np.linalg.det(got) == pytest.approx(1.0)


def test_the_head_between_sampled_frames_turns_half_way_and_gaps_stay_unknown() -> None:
    rows = np.array([0, 2, 4])
    yaws = [0.0, 0.4, np.nan]
    axes = np.stack([Rotation.from_euler("Z", y).as_matrix() for y in np.nan_to_num(yaws)])
    axes[2] = np.nan
    got, _, residual = head_pose.spread_heads(
        rows,
        axes[:, None],
        centre=np.zeros((3, 1, 2)),
        residual=np.array([[0.01], [0.02], [np.nan]]),
        n_frames=6,
    )
    half = Rotation.from_matrix(got[1, 0]).as_euler("ZYX")
    assert half == pytest.approx([0.2, 0.0, 0.0], abs=0.01)
    np.testing.assert_allclose(got[2, 0], axes[1], atol=1e-12)
    assert residual[1, 0] == pytest.approx(0.02)
    assert np.isnan(got[3:]).all()  # frame 3 lies next to an unmeasured sample; 5 after the last


def test_head_box_takes_turned_faces_the_mouth_does_not() -> None:
    kp = np.full((len(COCO17), 3), np.nan, np.float32)
    for name, xy in (("nose", (115, 110)), ("left_eye", (113, 95)), ("right_eye", (107, 95))):
        kp[COCO17.index[name]] = (*xy, 0.9)
    kp[COCO17.index["left_ear"]] = (80, 100, 0.9)  # the seen ear, behind the eyes
    # turn 1.67 (5 px from the eyes' midpoint, eyes 6 px apart): the mouth's limit is 1
    assert mouth.face_box(keypoints=kp, skeleton=COCO17.name, config=SpeechConfig())[1] == (
        "facing away"
    )
    limits = {"min_confidence": 0.5, "max_turn": 2.75, "min_px": 24.0}
    roi, why = head_pose.head_box(keypoints=kp, skeleton=COCO17.name, **limits)
    assert why == "" and roi is not None and (roi.cx, roi.cy) == (115, 110)
    # the eyes make the face 2.3 × 6 × √(1 + 1.67²) = 27 px wide, the ear 1.4 × 36.4 = 51 px
    assert roi.side == pytest.approx(2 * 1.4 * np.hypot(35, 10))
    kp[COCO17.index["nose"]] = (120, 110, 0.9)  # turn 3.3
    assert head_pose.head_box(keypoints=kp, skeleton=COCO17.name, **limits)[1] == "facing away"


@pytest.fixture(scope="module")
def model():
    from gesturebank.extract.mouth import FaceLandmarker

    return FaceLandmarker()


def _photo_head(model, angle_deg: float, mirror: bool = False) -> np.ndarray:
    """The head's axes the model and fit give for the astronaut photo turned `angle_deg` in
    the image (counter-clockwise as seen), mirrored first if asked."""
    import cv2
    from skimage import data

    photo = data.astronaut()
    if mirror:
        photo = np.ascontiguousarray(photo[:, ::-1])
    turn = cv2.getRotationMatrix2D((512.0 - 225.0 if mirror else 225.0, 124.0), angle_deg, 1.0)
    image = cv2.warpAffine(photo, turn, (512, 512), borderMode=cv2.BORDER_REPLICATE)
    x = 512.0 - 225.0 if mirror else 225.0
    mesh = model(image, Roi(x, 124.0, 202.0, -np.deg2rad(angle_deg)))
    mesh = model(image, head_pose.mesh_roi(mesh.points))
    return head_pose.fit_head(mesh.points3d).axes


def test_the_model_on_the_photo_turned_in_the_image_gives_that_roll(model) -> None:
    level = _photo_head(model, 0.0)
    tilted = _photo_head(model, 25.0)
    # counter-clockwise in the image (y down): the head's left axis turns from +x towards −y
    left0, left1 = level[:2, 1], tilted[:2, 1]
    turned = np.degrees(np.arctan2(left0[0] * -left1[1] + left0[1] * left1[0], left0 @ left1))
    assert turned == pytest.approx(25.0, abs=3.0)
    assert np.degrees(np.arccos(np.clip(level[:, 0] @ tilted[:, 0], -1, 1))) < 5.0


def test_the_reference_faces_the_camera(model) -> None:
    """The photo measured again comes back level; its mirror image turns by twice the photo's
    own yaw (its left-right asymmetry), which is small: the reference's zero is frontal."""
    a, b = _photo_head(model, 0.0), _photo_head(model, 0.0, mirror=True)
    yaw_a = np.degrees(np.arctan2(-a[0, 0], -a[2, 0]))
    yaw_b = np.degrees(np.arctan2(-b[0, 0], -b[2, 0]))
    assert abs(yaw_a) < 1.0
    assert abs(yaw_b) < 5.0
