"""The BVH reader, forward kinematics and writer, on the real bvhtools files (samples)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gesturebank.config import MocapConfig
from gesturebank.errors import InputError
from gesturebank.mocap.bvh import Motion, format_bvh, forward_kinematics, parse_bvh, read_bvh
from gesturebank.mocap.pose import motion_pose, unit_scale

FILES = "bvhtools/testBvhFiles"


@pytest.fixture(scope="module")
def lafan(samples: Path) -> Motion:
    """test.bvh: 22 joints, LAFAN1-style names, ZYX rotations, cm, 30 fps."""
    return read_bvh(samples / FILES / "test.bvh")


@pytest.fixture(scope="module")
def rig(samples: Path) -> Motion:
    """test3.bvh: a Blender rig, XYZ and YXZ rotations, position channels on every joint, m."""
    return read_bvh(samples / FILES / "test3.bvh")


def test_reads_what_the_file_says(lafan: Motion, rig: Motion) -> None:
    assert len(lafan) == 7184 and lafan.frame_time == pytest.approx(0.033333)
    assert sum(not e for e in lafan.end_site) == 22 and lafan.values.shape == (7184, 69)
    assert len(rig) == 3089 and rig.frame_time == pytest.approx(0.041667)
    assert rig.channels[rig.index["shoulder.L"]][3:] == ("Yrotation", "Xrotation", "Zrotation")


def test_channel_values_match_an_independent_parser(samples: Path, rig: Motion) -> None:
    """The `bvh` package (test-only dependency) reads the same numbers for every joint."""
    from bvh import Bvh

    theirs = Bvh((samples / FILES / "test3.bvh").read_text())
    for joint in ("pelvis", "neck", "shoulder.L", "forearm.R", "foot.L"):
        chans = list(rig.channels[rig.index[joint]])
        for frame in (0, 1000, 3088):
            want = theirs.frame_joint_channels(frame, joint, chans)
            np.testing.assert_allclose(rig.values[frame, rig.columns(joint)], want, atol=1e-9)


@pytest.mark.parametrize("order", ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"])
def test_every_euler_order_is_the_intrinsic_product(order: str) -> None:
    """Channels `A B C` rotate by Ra·Rb·Rc, compared with scipy's intrinsic Euler angles."""
    rng = np.random.default_rng(len(order) + ord(order[0]))
    angles = rng.uniform(-180, 180, (50, 3))
    text = (
        "HIERARCHY\nROOT a\n{\n OFFSET 0 0 0\n CHANNELS 3 "
        + " ".join(f"{ax}rotation" for ax in order)
        + "\n End Site\n {\n  OFFSET 1 2 3\n }\n}\nMOTION\nFrames: 50\nFrame Time: 0.01\n"
        + "\n".join(" ".join(f"{v:.9f}" for v in row) for row in angles)
    )
    pos, rot = forward_kinematics(parse_bvh(text))
    want = Rotation.from_euler(order, angles, degrees=True)
    np.testing.assert_allclose(rot[:, 0], want.as_matrix(), atol=1e-9)
    np.testing.assert_allclose(pos[:, 1], want.apply([1.0, 2.0, 3.0]), atol=1e-9)


def test_position_channels_replace_the_offset(rig: Motion) -> None:
    """test3.bvh's joints all carry position channels equal to their offsets: with them
    replacing the offset the bones are rigid (adding them would double every bone)."""
    pos, _ = forward_kinematics(rig)
    at = rig.index
    for a, b in (("upper_arm.L", "forearm.L"), ("thigh.R", "shin.R"), ("neck", "face")):
        length = np.linalg.norm(pos[:, at[b]] - pos[:, at[a]], axis=1)
        assert length.std() < 1e-5 * length.mean()
        np.testing.assert_allclose(length.mean(), np.linalg.norm(rig.offsets[at[b]]), rtol=1e-4)


@pytest.mark.parametrize("name", ["lafan", "rig"])
def test_written_and_read_back_gives_the_same_joints(
    name: str, request: pytest.FixtureRequest
) -> None:
    motion: Motion = request.getfixturevalue(name)
    scale = unit_scale(motion, "auto")
    again = parse_bvh(format_bvh(motion))
    assert again.names == motion.names and again.channels == motion.channels
    a, _ = forward_kinematics(motion)
    b, _ = forward_kinematics(again)
    assert np.abs(a - b).max() * scale <= 1e-4


def test_units_are_told_from_the_skeleton(lafan: Motion, rig: Motion) -> None:
    """test.bvh spans 2.36 (cm → 2.36 m: toe to head); test3.bvh 2.02 (m)."""
    assert unit_scale(lafan, "auto") == 0.01
    assert unit_scale(rig, "auto") == 1.0
    assert unit_scale(lafan, "in") == 0.0254
    pose, _ = motion_pose(lafan.frames(0, 10))
    shoulders = np.linalg.norm(pose.joint("left_shoulder") - pose.joint("right_shoulder"), axis=1)
    assert 0.25 < shoulders.mean() < 0.5  # metres, a person's shoulder width


def test_the_joints_that_map(lafan: Motion, rig: Motion) -> None:
    _, names = motion_pose(lafan.frames(0, 2))
    assert names == {
        "left_shoulder": "LeftArm",
        "right_shoulder": "RightArm",
        "left_elbow": "LeftForeArm",
        "right_elbow": "RightForeArm",
        "left_wrist": "LeftHand",
        "right_wrist": "RightHand",
        "left_hip": "LeftUpLeg",
        "right_hip": "RightUpLeg",
        "left_knee": "LeftLeg",
        "right_knee": "RightLeg",
        "left_ankle": "LeftFoot",
        "right_ankle": "RightFoot",
        "head": "Head",
    }
    _, names = motion_pose(rig.frames(0, 2))
    assert names["left_wrist"] == "forearm.L_End" and names["head"] == "face"


def test_unknown_skeleton_is_one_line_naming_joints_and_the_key(
    tmp_path: Path, samples: Path
) -> None:
    text = (samples / FILES / "test.bvh").read_text()
    for old, new in (("LeftArm", "Bicep_L"), ("RightArm", "Bicep_R")):
        text = text.replace(f"JOINT {old}\n", f"JOINT {new}\n")
    path = tmp_path / "odd.bvh"
    path.write_text(text)
    motion = read_bvh(path)
    with pytest.raises(InputError) as err:
        motion_pose(motion, source=str(path))
    msg = str(err.value)
    assert "\n" not in msg and str(path) in msg
    assert "left_shoulder, right_shoulder" in msg and "Bicep_L" in msg and "mocap.names" in msg
    mapped = MocapConfig(names={"Bicep_L": "left_shoulder", "Bicep_R": "right_shoulder"})
    _, names = motion_pose(motion, config=mapped)
    assert names["left_shoulder"] == "Bicep_L"


@pytest.mark.parametrize(
    ("cut", "words"),
    [
        (lambda t: t.replace("MOTION", "MOTON"), "no MOTION"),
        (lambda t: t[: len(t) - 2000], "values, found"),
        (lambda t: t.replace("Frame Time: 0.033333", "Frame Time: abc"), "not a number"),
        (lambda t: t.replace("Frame Time: 0.033333", "Frame Time: 0"), "must be positive"),
        (lambda t: t.replace("Xrotation", "Wrotation", 1), "unknown channel"),
    ],
)
def test_broken_files_name_the_file(tmp_path: Path, samples: Path, cut, words: str) -> None:
    path = tmp_path / "broken.bvh"
    path.write_text(cut((samples / FILES / "test2.bvh").read_text()))
    with pytest.raises(InputError, match=words) as err:
        read_bvh(path)
    assert str(path) in str(err.value)
