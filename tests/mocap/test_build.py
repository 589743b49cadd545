"""A real mocap take (a bvhtools BVH with real speech beside it) builds like a video."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gesturebank import datasets
from gesturebank.robot.pepper import INDEX, load_profile
from gesturebank.testing.mocap import mocap_take

BIN = Path(sys.executable).parent

# Which BVH joint stands for each point (LAFAN1-style names; "LeftArm" is the shoulder joint,
# "LeftShoulder" the clavicle, which no point uses). The face is placed on "Head".
JOINTS = {
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


@pytest.fixture(scope="module")
def built(samples: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("mocap-takes")
    mocap_take(samples, root / "freemocap", name="talk")
    out = root / "out"
    r = subprocess.run(
        [str(BIN / "build-dataset"), str(root), str(out), "--workers", "1", "--quiet"],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    return out


def test_builds_into_accepted_clips(built: Path) -> None:
    record = json.loads((built / "takes" / "freemocap__talk.json").read_text())
    assert record["detector"] == record["lifter"] == "mocap"
    assert record["tracking"]["joints"] == JOINTS
    assert record["tracking"]["metres_per_unit"] == "0.01"  # test.bvh is in centimetres
    clips = [c for c in record["clips"] if c["kind"] == "clip"]
    assert [c["qc_status"] for c in clips] == ["accepted"], [c["qc_reasons"] for c in clips]
    assert clips[0]["duration_s"] > 3.5  # 4.0 s of speech on 4.2 s of motion


def test_angles_are_plausible_and_inside_the_limits(built: Path) -> None:
    data = datasets.open(built)
    (clip_id,) = data.clip_ids()
    clip = data.load(clip_id)
    profile = load_profile(data.info.robot_profile)
    a = clip.angles
    assert clip.mask.all() and np.isfinite(a).all()  # mocap sees every joint
    assert np.all(a >= profile.lower - 1e-6) and np.all(a <= profile.upper + 1e-6)
    deg = np.rad2deg(a)
    span = np.ptp(deg, axis=0)
    # Measured on this stretch: the left arm swings up (LShoulderPitch 31° → 97°) and bends
    # (LElbowRoll −23° → −61°); the right arm is lower and bent (RShoulderPitch 76° → 119°,
    # RElbowRoll 42° → 82°); the head turns (HeadYaw −21° → 31°) and stays near level.
    assert span[INDEX["LShoulderPitch"]] > 45 and span[INDEX["RShoulderPitch"]] > 25
    assert span[INDEX["LElbowRoll"]] > 25 and span[INDEX["HeadYaw"]] > 30
    assert np.all(deg[:, INDEX["LElbowRoll"]] < 0) and np.all(deg[:, INDEX["RElbowRoll"]] > 0)
    assert np.all(np.abs(deg[:, INDEX["HeadPitch"]]) < 25)
    assert np.all(np.abs(deg[:, INDEX["HipRoll"]]) < 10)  # standing
    # the arms hang below the horizontal most of the time (ShoulderPitch > 0 = below forward)
    assert np.median(deg[:, [INDEX["LShoulderPitch"], INDEX["RShoulderPitch"]]]) > 30
    # raw angles (before the clamp) already lie inside the limits: nothing was cut off
    raw = clip.raw_angles
    assert np.all(raw >= profile.lower - 0.01) and np.all(raw <= profile.upper + 0.01)


def test_a_bvh_without_audio_fails_with_its_reason(samples: Path, tmp_path: Path) -> None:
    from gesturebank.app.build import build_dataset
    from gesturebank.config import Config
    from gesturebank.datasets.takes import discover_takes

    bvh = mocap_take(samples, tmp_path / "in", name="silent")
    bvh.with_suffix(".wav").unlink()
    summary = build_dataset(
        discover_takes(tmp_path / "in"),
        videos_dir=tmp_path / "in",
        out=tmp_path / "out",
        config=Config(),
    )
    (failed,) = summary.failed
    assert "no silent.wav beside it" in failed.reason


def test_subjects_csv_can_name_the_audio(samples: Path, tmp_path: Path) -> None:
    from gesturebank.datasets.takes import discover_takes

    bvh = mocap_take(samples, tmp_path / "mocap", name="talk")
    (tmp_path / "audio").mkdir()
    bvh.with_suffix(".wav").rename(tmp_path / "audio" / "speech.wav")
    (tmp_path / "subjects.csv").write_text(
        "take,subject,audio,age\ntalk,anna,audio/speech.wav,30\n"
    )
    (take,) = discover_takes(tmp_path)
    assert take.mocap and take.audio == tmp_path / "audio" / "speech.wav"
    assert take.subject == "anna" and take.traits == {"age": "30"}
