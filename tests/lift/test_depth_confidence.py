"""The depth-sign confidence (lift.depth_confidence): Eq. (1) against bones of known tilt,
Eq. (2)'s range and monotony, and the calibration table against a measurement."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gesturebank.lift.clip_confidence import expected_hand_error_cm, lifter_traits
from gesturebank.lift.depth_confidence import (
    ARM_BONES,
    depth_confidence,
    out_of_plane_share,
    pose_confidence,
)
from gesturebank.skeletons import COCO17

_I = COCO17.index
share = st.floats(0.0, 1.0)


def _person(tilts: np.ndarray) -> np.ndarray:
    """(T, 17, 3) joints of a person facing the camera along z (x right, y down, metres): spine
    0.5 m, upper arms 0.3 m and forearms 0.25 m hanging, each arm bone tilted out of the image
    plane by `tilts` (T, 4) radians (ARM_BONES order)."""
    t = len(tilts)
    joints = np.full((t, 17, 3), np.nan)
    for side, x in (("left", 0.2), ("right", -0.2)):
        joints[:, _I[f"{side}_shoulder"]] = (x, 0.0, 3.0)
        joints[:, _I[f"{side}_hip"]] = (x * 0.6, 0.5, 3.0)
    lengths = (0.3, 0.25, 0.3, 0.25)
    for k, ((a, b), length) in enumerate(zip(ARM_BONES, lengths, strict=True)):
        bone = np.stack([np.zeros(t), np.cos(tilts[:, k]), np.sin(tilts[:, k])], -1) * length
        joints[:, b] = joints[:, a] + bone
    return joints


def _orthographic(joints: np.ndarray) -> np.ndarray:
    """Pixels of a camera far away (scaled orthographic, 1000 px per metre)."""
    return joints[..., :2] * 1000.0


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(0.0, 1.4), min_size=4, max_size=4))
def test_share_is_the_sine_of_a_bones_tilt(tilt: list[float]) -> None:
    """Eq. (1) of a bone tilted by θ out of the image plane is sin θ: a level frame gives the
    proportions (a frame with every bone in the image plane), the second frame the tilts."""
    tilts = np.array([[0.0] * 4, tilt])
    joints = _person(tilts)
    got = out_of_plane_share(xy=_orthographic(joints), joints=joints)
    np.testing.assert_allclose(got[1], np.sin(tilts[1]), atol=1e-6)
    np.testing.assert_allclose(got[0], 0.0, atol=1e-6)


@settings(max_examples=60, deadline=None)
@given(st.lists(share | st.just(float("nan")), min_size=4, max_size=4))
def test_confidence_is_within_zero_and_one(s: list[float]) -> None:
    c = depth_confidence(share=np.array([s]))
    assert c.dtype == np.float32 and c.shape == (1,)
    assert 0.0 <= float(c[0]) <= 1.0


@settings(max_examples=60, deadline=None)
@given(st.lists(share, min_size=4, max_size=4), st.integers(0, 3), share)
def test_confidence_falls_as_a_bone_leaves_the_image_plane(
    s: list[float], bone: int, more: float
) -> None:
    """Monotone: raising one bone's out-of-plane share never raises the confidence, and lowers
    it when that bone becomes the one furthest out of the plane (Eq. 2 takes the largest)."""
    before = np.array([s])
    after = before.copy()
    after[0, bone] = max(s[bone], more)
    c0 = depth_confidence(share=before)[0]
    c1 = depth_confidence(share=after)[0]
    assert c1 <= c0 + 1e-7
    if after[0, bone] > before.max() + 1e-3:
        assert c1 < c0
        assert abs(c1 - (1 - after[0, bone])) < 1e-6


def test_in_plane_arms_are_certain_and_unseen_ones_do_not_count() -> None:
    assert depth_confidence(share=np.zeros((1, 4)))[0] == 1.0
    assert depth_confidence(share=np.full((1, 4), np.nan))[0] == 1.0  # masked, not guessed
    one = depth_confidence(share=np.array([[np.nan, 1.0, 0.0, 0.0]]))
    assert one[0] == 0.0  # a forearm along the camera's ray: nothing in the image says which way


def test_arms_pointing_at_the_camera_lower_a_lifted_frame() -> None:
    """pose_confidence of a person whose forearms turn from hanging (frame 0) to pointing at
    the camera (frame 1): the second frame is less certain."""
    tilts = np.array([[0.0, 0.0, 0.0, 0.0], [0.2, 1.4, 0.2, 1.4]])
    joints = _person(tilts)
    xy = _orthographic(joints)
    c = pose_confidence(xy=xy, joints=joints)
    assert c[0] > 0.99 and abs(c[1] - (1 - np.sin(1.4))) < 1e-6


def test_expected_hand_error_follows_the_calibration() -> None:
    """The table's own points come back; below its lowest bin it holds the end; an unknown
    lifter has no expectation. The calibrated lifters are the three measured (their traits)."""
    calibrated = {
        name: lifter_traits(name).depth_calibration
        for name in ("blazepose-world", "learned", "resolved", "fitted", "geometric", "multiview")
    }
    assert [name for name, table in calibrated.items() if table is not None] == [
        "blazepose-world",
        "learned",
        "resolved",
    ]
    for lifter, table in calibrated.items():
        if table is None:
            continue
        middles, wrong, hand_cm = table
        assert list(middles) == sorted(middles) and len(middles) == len(hand_cm) == len(wrong)
        for c, cm in zip(middles, hand_cm, strict=True):
            got = expected_hand_error_cm(confidence=np.full(10, c), lifter=lifter)
            assert abs(got - cm) < 1e-9
        low = expected_hand_error_cm(confidence=np.zeros(3), lifter=lifter)
        assert low == hand_cm[0]
    assert np.isnan(expected_hand_error_cm(confidence=np.ones(3), lifter="no-such-lifter"))
