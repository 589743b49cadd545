"""Exports: Pepper and person BVH, TRC, CSV with units, NAOqi angleInterpolation files."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gesturebank import datasets
from gesturebank.app.build import build_dataset
from gesturebank.app.export import upright
from gesturebank.cli.export import export_command
from gesturebank.config import Config
from gesturebank.datasets import store
from gesturebank.datasets.takes import discover_takes
from gesturebank.export.pepper_bvh import pepper_motion
from gesturebank.export.person_bvh import person_motion
from gesturebank.export.trc import format_trc
from gesturebank.mocap.bvh import format_bvh, forward_kinematics, parse_bvh, read_bvh
from gesturebank.mocap.pose import motion_pose
from gesturebank.robot import pepper
from gesturebank.robot.retarget import pepper_angles
from gesturebank.skeletons import COCO17
from gesturebank.testing.mocap import mocap_take

BIN = Path(sys.executable).parent


@pytest.fixture(scope="module")
def dataset(samples: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A dataset with one accepted clip, built from a real BVH and real speech."""
    root = tmp_path_factory.mktemp("export")
    mocap_take(samples, root / "takes", name="talk")
    out = root / "dataset"
    summary = build_dataset(
        discover_takes(root / "takes"), videos_dir=root / "takes", out=out, config=Config()
    )
    assert not summary.failed and datasets.open(out).clip_ids()
    return out


def _poses(n: int) -> np.ndarray:
    """Random Pepper poses away from the retargeting's singular bands (straight elbow within
    34°, arm within 20° of the lateral axis): there `pepper_angles` inverts FK exactly."""
    rng = np.random.default_rng(7)
    lo = [-0.6, -1.5, 0.1, -1.5, -1.5, -1.5, -1.2, -1.5, 0.6, -1.5, -0.4]
    hi = [0.4, 1.5, 1.2, 1.5, -0.6, 1.5, -0.1, 1.5, 1.5, 1.5, 0.4]
    return rng.uniform(lo, hi, (n, 11))


def test_pepper_bvh_fk_gives_back_the_angles() -> None:
    """Pepper BVH → text → our parser's FK → retargeting: the same angles within 0.01°, and
    the BVH's joints are where Pepper's own FK puts them."""
    angles = _poses(3000)
    motion = parse_bvh(format_bvh(pepper_motion(angles=angles, frame_time=0.01, kinematics="urdf")))
    pos, _ = forward_kinematics(motion)
    fk = pepper.fk(angles)
    for joint, point in (("LWrist", "left_wrist"), ("RElbow", "right_elbow"), ("Head", "head")):
        robot = fk[point][:, [1, 2, 0]] * 100  # BVH x left, y up, z forward, cm
        np.testing.assert_allclose(pos[:, motion.index[joint]], robot, atol=1e-4)
    pose, names = motion_pose(motion)
    assert names["left_shoulder"] == "LShoulder" and names["head"] == "Head"
    err = np.rad2deg(np.abs(pepper_angles(pose) - angles))
    assert err.max() <= 0.01, err.max(axis=0)


def test_pepper_bvh_channels_read_by_the_bvh_package(tmp_path: Path) -> None:
    """An independent parser (`bvh` from the package registry, test-only) reads the angles
    back as the channels say: degrees, HipRoll negated on the torso's Zrotation."""
    from bvh import Bvh

    angles = _poses(50)
    path = tmp_path / "pepper.bvh"
    path.write_text(format_bvh(pepper_motion(angles=angles, frame_time=0.01, kinematics="urdf")))
    theirs = Bvh(path.read_text())
    assert theirs.nframes == 50 and theirs.frame_time == pytest.approx(0.01)
    deg = np.rad2deg(angles)
    J = pepper.INDEX
    for f in (0, 17, 49):
        got = theirs.frame_joint_channels(f, "LShoulder", ["Xrotation", "Yrotation"])
        np.testing.assert_allclose(
            got, deg[f, [J["LShoulderPitch"], J["LShoulderRoll"]]], atol=1e-5
        )
        got = theirs.frame_joint_channels(f, "RElbow", ["Zrotation", "Yrotation"])
        np.testing.assert_allclose(got, deg[f, [J["RElbowYaw"], J["RElbowRoll"]]], atol=1e-5)
        got = theirs.frame_joint_channels(f, "Head", ["Yrotation", "Xrotation"])
        np.testing.assert_allclose(got, deg[f, [J["HeadYaw"], J["HeadPitch"]]], atol=1e-5)
        got = theirs.frame_joint_channel(f, "Torso", "Zrotation")
        assert got == pytest.approx(-deg[f, J["HipRoll"]], abs=1e-5)
    assert theirs.joint_offset("LShoulder") == pytest.approx([14.974, 22.582, -5.7])  # URDF, cm


def test_person_bvh_round_trip(dataset: Path) -> None:
    """A clip's 3D joints → person BVH → read back: the same positions within 1e-4 m."""
    data = datasets.open(dataset)
    clip = data.load(data.clip_ids()[0])
    joints = upright(clip.pose3d.joints, layout="bvh")
    motion = parse_bvh(format_bvh(person_motion(joints=joints, frame_time=1 / 30)))
    pose, _ = motion_pose(motion)  # the face points are joints of this file
    assert np.abs(pose.joints - joints).max() <= 1e-4


def test_person_bvh_leaves_out_joints_never_seen(dataset: Path) -> None:
    """A waist-up video clip has no legs: they are left out; a wrist missing in some frames
    keeps its median offset there and is exact elsewhere."""
    data = datasets.open(dataset)
    joints = upright(data.load(data.clip_ids()[0]).pose3d.joints, layout="bvh")
    i = COCO17.index
    joints[:, [i["left_knee"], i["right_knee"], i["left_ankle"], i["right_ankle"]]] = np.nan
    joints[10:20, i["left_wrist"]] = np.nan
    motion = person_motion(joints=joints, frame_time=1 / 30)
    assert "left_knee" not in motion.names and "left_hip" in motion.names
    pose, _ = motion_pose(parse_bvh(format_bvh(motion)))
    seen = np.isfinite(joints).all(axis=-1)
    assert np.abs(pose.joints[seen] - joints[seen]).max() <= 1e-4
    assert np.isnan(pose.joints[:, i["left_knee"]]).all()
    assert np.isfinite(pose.joints[10:20, i["left_wrist"]]).all()


def _read_trc(path: Path) -> tuple[dict[str, str], list[str], np.ndarray, np.ndarray]:
    """A TRC reader written to the format's description (OpenSim's "Marker (.trc) files"):
    line 1 PathFileType; line 2 the header names and line 3 their values; line 4 `Frame#`,
    `Time` and the marker names each over three columns; line 5 X/Y/Z labels; then rows
    of frame, time, x y z per marker (empty cells = missing)."""
    lines = path.read_text().split("\n")
    assert lines[0].split("\t")[:3] == ["PathFileType", "4", "(X/Y/Z)"]
    header = dict(zip(lines[1].split("\t"), lines[2].split("\t"), strict=True))
    names = [n for n in lines[3].split("\t")[2:] if n]
    labels = lines[4].split("\t")[2:]
    assert labels == [f"{a}{i}" for i in range(1, len(names) + 1) for a in "XYZ"]
    rows = [ln.split("\t") for ln in lines[5:] if ln.strip()]
    frames = np.array([int(r[0]) for r in rows])
    assert list(frames) == list(range(1, len(rows) + 1))
    times = np.array([float(r[1]) for r in rows])
    values = np.array([[float(c) if c else np.nan for c in r[2:]] for r in rows])
    return header, names, times, values.reshape(len(rows), len(names), 3)


def test_trc_reads_back_to_the_spec(dataset: Path, tmp_path: Path) -> None:
    clip_id = datasets.open(dataset).clip_ids()[0]
    (path,) = export_command(
        src=next(dataset.glob(f"takes/*/{clip_id}.npz")),
        fmt="trc",
        out=tmp_path / "c.trc",
        config=Config(),
    )
    header, names, times, markers = _read_trc(path)
    assert names == list(COCO17.joints)
    assert header["Units"] == "m" and int(header["NumMarkers"]) == 17
    assert int(header["NumFrames"]) == len(times) == len(markers)
    rate = float(header["DataRate"])
    assert rate == pytest.approx(30.0, rel=1e-3)  # the BVH's own 30 fps
    np.testing.assert_allclose(np.diff(times), 1 / rate, atol=1e-5)
    # OpenSim axes: y up (head above hips), metres (shoulders ~0.3 m apart)
    i = COCO17.index
    assert np.all(markers[:, i["nose"], 1] > markers[:, i["left_hip"], 1] + 0.4)
    width = np.linalg.norm(markers[:, i["left_shoulder"]] - markers[:, i["right_shoulder"]], axis=1)
    assert 0.25 < width.mean() < 0.5
    # the same joints as the clip's, moved rigidly (distances kept)
    clip = datasets.open(dataset).load(clip_id)
    d_clip = np.linalg.norm(
        clip.pose3d.joints[0, i["left_wrist"]] - clip.pose3d.joints[0, i["nose"]]
    )
    d_trc = np.linalg.norm(markers[0, i["left_wrist"]] - markers[0, i["nose"]])
    assert d_trc == pytest.approx(d_clip, abs=1e-5)


def test_trc_leaves_missing_markers_empty() -> None:
    markers = np.arange(2 * 2 * 3, dtype=float).reshape(2, 2, 3)
    markers[1, 0] = np.nan
    text = format_trc(markers=markers, names=["a", "b"], rate_hz=50.0, filename="x.trc")
    assert text.splitlines()[-1] == "2\t0.020000\t\t\t\t9.000000\t10.000000\t11.000000"


def test_cli_exports_every_format(dataset: Path, tmp_path: Path) -> None:
    clip_id = datasets.open(dataset).clip_ids()[0]
    for fmt in ("bvh", "trc", "csv", "naoqi"):
        r = subprocess.run(
            [
                str(BIN / "gesturebank"),
                "export",
                str(dataset),
                "--format",
                fmt,
                "--out",
                str(tmp_path / fmt),
            ],
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
        assert r.returncode == 0, r.stderr
    assert read_bvh(tmp_path / "bvh" / f"{clip_id}.bvh").names[0] == "Hip"
    person = read_bvh(tmp_path / "bvh" / f"{clip_id}_person.bvh")
    assert "left_wrist" in person.names
    lines = (tmp_path / "csv" / f"{clip_id}.angles.csv").read_text().splitlines()
    reach = store.read_dataset_json(dataset).config.retarget.reach  # the dataset's own mode
    assert "pepper-1.7" in lines[0] and f"reach: {reach}" in lines[0]
    assert lines[1].startswith("time_s,HeadPitch,HeadYaw,")
    data = json.loads((tmp_path / "naoqi" / f"{clip_id}.naoqi.json").read_text())
    assert data["names"] == list(pepper.JOINTS) and data["isAbsolute"] is True
    times = np.array(data["timeLists"][0])
    assert times[0] == pytest.approx(Config().playback.start_s) and np.all(np.diff(times) > 0)
    profile = pepper.load_profile()
    a = np.array(data["angleLists"])  # (11, N), inside the limits as replay plays them
    assert np.all(a.T >= profile.lower - 1e-6) and np.all(a.T <= profile.upper + 1e-6)
    script = (tmp_path / "naoqi" / f"{clip_id}.naoqi.py").read_text()
    compile(script, "naoqi.py", "exec")
    assert "angleInterpolation" in script and f"{clip_id}.naoqi.json" in script


def test_cli_export_of_an_angles_csv(tmp_path: Path) -> None:
    from gesturebank.robot.timeline import Timeline, write_timeline

    angles = _poses(200).astype(np.float32)
    write_timeline(tmp_path / "angles.csv", Timeline.of(np.arange(200) / 100, angles))
    r = subprocess.run(
        [
            str(BIN / "gesturebank"),
            "export",
            str(tmp_path / "angles.csv"),
            "--format",
            "bvh",
            "--out",
            str(tmp_path / "pepper.bvh"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert r.returncode == 0, r.stderr
    assert len(read_bvh(tmp_path / "pepper.bvh")) == 200
    r = subprocess.run(
        [str(BIN / "gesturebank"), "export", str(tmp_path / "angles.csv"), "--format", "trc"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        cwd=tmp_path,
    )
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "trc needs a clip" in r.stderr


def test_exported_script_plays_the_speech_on_the_robot_in_step(tmp_path: Path) -> None:
    """The exported script run against the local qi peer, whose sound starts 300 ms after its
    first buffer: the motion after frame 0 follows the start the peer reports."""
    import wave

    from gesturebank.robot.timeline import Timeline, write_timeline
    from gesturebank.testing.naoqi_server import NaoqiServer

    n, rate = 100, 16000
    write_timeline(tmp_path / "angles.csv", Timeline.of(np.arange(n) / 100, _poses(n)))
    tone = (0.3 * np.sin(np.arange(rate) * 2 * np.pi * 220 / rate) * 32767).astype("<i2")
    with wave.open(str(tmp_path / "speech.wav"), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(rate)
        w.writeframes(tone.tobytes())
    written = export_command(
        src=tmp_path / "angles.csv",
        fmt="naoqi",
        out=tmp_path / "out" / "talk.naoqi.json",
        config=Config(),
        audio=tmp_path / "speech.wav",
    )
    assert sorted(p.name for p in written) == ["talk.naoqi.json", "talk.naoqi.py", "talk.naoqi.wav"]
    with wave.open(str(tmp_path / "out" / "talk.naoqi.wav")) as w:
        assert (w.getframerate(), w.getnchannels(), w.getsampwidth()) == (48000, 2, 2)
    data = json.loads((tmp_path / "out" / "talk.naoqi.json").read_text())
    with NaoqiServer(lifetime_s=90, audio_delay_s=0.3) as srv:
        run = subprocess.run(
            [sys.executable, str(tmp_path / "out" / "talk.naoqi.py"), srv.url],
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
        assert run.returncode == 0, run.stderr
        calls = srv.calls()
    names = [c["call"] for c in calls]
    # the first pose, then the speech asked for, its start reported, then the rest of the motion
    assert names.count("angleInterpolation") == 2
    first, second = (k for k, c in enumerate(names) if c == "angleInterpolation")
    start = names.index("audioStart")
    assert first < names.index("sendRemoteBufferToOutput") < start < second
    assert calls[start]["t"] - calls[names.index("sendRemoteBufferToOutput")]["t"] >= 0.3
    lag_ms = (calls[second]["t"] - calls[start]["t"]) * 1000
    assert 0 <= lag_ms <= 50, lag_ms
    # its keys land where the timeline has them, counted from the robot's sound start
    times = np.asarray(data["timeLists"][0]) - data["timeLists"][0][0]
    keys = np.asarray(calls[second]["timeLists"][0]) + calls[second]["t"] - calls[start]["t"]
    np.testing.assert_allclose(keys, times[-len(keys) :], atol=0.05)
    frames = sum(c["frames"] for c in calls if c["call"] == "sendRemoteBufferToOutput")
    assert frames == 48000
