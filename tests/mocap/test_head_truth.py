"""The truth's head angles: a BVH head joint turned by a known yaw and pitch, read by the
project's own reader (face points placed by the face model), retargeted, gives that yaw and
pitch — no constant offset, no sign or axis mix-up, no wrap, whatever the body's heading."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gesturebank.config import MocapConfig
from gesturebank.mocap.bvh import Motion
from gesturebank.mocap.pose import motion_pose
from gesturebank.robot.pepper import JOINTS
from gesturebank.robot.retarget import pepper_angles

ROOT = ("Xposition", "Yposition", "Zposition", "Yrotation", "Xrotation", "Zrotation")
TURN = ("Yrotation", "Xrotation", "Zrotation")  # intrinsic: yaw about up, then pitch, then roll
# A y-up person facing +z (left = +x), metres: (name, parent, offset, channels).
SKELETON = (
    ("Hips", -1, (0.0, 1.0, 0.0), ROOT),
    ("LeftUpLeg", 0, (0.1, 0.0, 0.0), ()),
    ("RightUpLeg", 0, (-0.1, 0.0, 0.0), ()),
    ("Spine", 0, (0.0, 0.3, 0.0), ()),
    ("Neck", 3, (0.0, 0.25, 0.0), ()),
    ("Head", 4, (0.0, 0.1, 0.0), TURN),
    ("LeftArm", 3, (0.18, 0.22, 0.0), ()),
    ("LeftForeArm", 6, (0.0, -0.28, 0.0), ()),
    ("LeftHand", 7, (0.0, -0.25, 0.0), ()),
    ("RightArm", 3, (-0.18, 0.22, 0.0), ()),
    ("RightForeArm", 9, (0.0, -0.28, 0.0), ()),
    ("RightHand", 10, (0.0, -0.25, 0.0), ()),
)


def _motion(heading: float, yaw: float, pitch: float, roll: float) -> Motion:
    """One frame: the body turned by `heading` about the vertical, the head by yaw (to its
    left), pitch (face down) and roll, degrees."""
    # BVH Xrotation turns +z (the face) towards −y (down): a positive X angle is a nod down.
    values = np.array([[0.0, 1.0, 0.0, heading, 0.0, 0.0, yaw, pitch, roll]])
    return Motion(
        names=tuple(s[0] for s in SKELETON),
        parents=tuple(s[1] for s in SKELETON),
        offsets=np.array([s[2] for s in SKELETON]),
        channels=tuple(s[3] for s in SKELETON),
        end_site=(False,) * len(SKELETON),
        values=values,
        frame_time=1 / 30,
    )


@settings(max_examples=60, deadline=None)
@given(
    heading=st.floats(-180, 180),
    yaw=st.floats(-85, 85),
    pitch=st.floats(-40, 40),
)
def test_head_joint_turn_is_the_truths_head_yaw_and_pitch(
    heading: float, yaw: float, pitch: float
) -> None:
    pose, _ = motion_pose(_motion(heading, yaw, pitch, 0.0), config=MocapConfig(units="m"))
    angles = np.rad2deg(pepper_angles(pose)[0].astype(np.float64))
    got_yaw, got_pitch = angles[JOINTS.index("HeadYaw")], angles[JOINTS.index("HeadPitch")]
    assert abs((got_yaw - yaw + 180) % 360 - 180) < 0.05
    assert abs(got_pitch - pitch) < 0.05


@settings(max_examples=40, deadline=None)
@given(yaw=st.floats(-60, 60), pitch=st.floats(-30, 30), roll=st.floats(-30, 30))
def test_a_head_tilted_sideways_keeps_its_heading(yaw: float, pitch: float, roll: float) -> None:
    # Roll about the face's own axis (last, intrinsic) moves neither the face direction nor,
    # hence, HeadYaw and HeadPitch (Pepper has no head roll).
    pose, _ = motion_pose(_motion(0.0, yaw, pitch, roll), config=MocapConfig(units="m"))
    angles = np.rad2deg(pepper_angles(pose)[0].astype(np.float64))
    assert abs(angles[JOINTS.index("HeadYaw")] - yaw) < 0.05
    assert abs(angles[JOINTS.index("HeadPitch")] - pitch) < 0.05
