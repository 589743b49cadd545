"""Multi-camera takes (docs/architecture.md "What a take is"): found as one take, lifted by
triangulation."""

from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

from gesturebank.app.build import build_dataset
from gesturebank.app.extract import extract_take
from gesturebank.camera_files import load_cameras
from gesturebank.config import Config
from gesturebank.datasets.store import Dataset
from gesturebank.datasets.takes import discover_takes, find_calibration
from gesturebank.lift import TakeViews
from gesturebank.lift.multiview.lifter import MultiviewLifter, match_videos
from gesturebank.repair import repair_pose2d, repair_pose3d

QCA = "<QCA_Camera_Calibration></QCA_Camera_Calibration>"


def touch(path: Path, text: str = "") -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def test_a_calibrated_folder_of_videos_is_one_take(tmp_path: Path) -> None:
    root = tmp_path / "videos"
    touch(root / "studio" / "calibration" / "Calib.qca.txt", QCA)
    for cam in ("cam01", "cam02", "cam03"):
        touch(root / "studio" / "videos" / f"{cam}.mp4")
    touch(root / "studio" / "speech.wav")
    touch(root / "solo" / "calibration.toml")  # one video: a calibration alone makes no rig
    touch(root / "solo" / "talk.mp4")
    touch(root / "anna" / "a.mp4")
    (tmp_path / "linked").symlink_to(root / "anna")
    (root / "bob").symlink_to(tmp_path / "linked")  # the same folder again: searched once
    touch(tmp_path / "elsewhere" / "c.mp4")
    (root / "carl").symlink_to(tmp_path / "elsewhere")  # linked folders are followed
    takes = {t.take_id: t for t in discover_takes(root)}
    assert set(takes) == {"studio", "solo__talk", "anna__a", "carl__c"}
    rig = takes["studio"]
    assert rig.multi_camera and rig.calibration == root / "studio/calibration/Calib.qca.txt"
    assert [v.name for v in rig.videos] == ["cam01.mp4", "cam02.mp4", "cam03.mp4"]
    assert rig.audio == root / "studio" / "speech.wav"
    assert rig.subject == "studio"
    assert not takes["solo__talk"].multi_camera


def test_pose2sim_demo_builds_as_a_multi_camera_take(samples: Path, tmp_path: Path) -> None:
    demo = samples / "pose2sim" / "Demo_SinglePerson"
    videos = tmp_path / "videos"
    videos.mkdir()
    (videos / "lab-4cams").symlink_to(demo)
    (videos / "clip.mp4").symlink_to(samples / "talking" / "lab" / "cam01_arctic.mp4")
    out = tmp_path / "out"
    # the demo lasts 1.67 s: shorter clips are kept here so the triangulated take gives one
    config = Config.model_validate({"lifter": {"name": "multiview"}, "clips": {"min_s": 1.0}})
    summary = build_dataset(discover_takes(videos), videos_dir=videos, out=out, config=config)
    assert summary.count("built") == 1
    assert [r.take_id for r in summary.failed] == ["clip"]  # one view cannot be triangulated
    assert "needs a multi-camera take" in summary.failed[0].reason
    rows = [r for r in pq.read_table(out / "manifest.parquet").to_pylist() if r["kind"] == "clip"]
    (row,) = rows
    assert (row["take_id"], row["lifter"]) == ("lab-4cams", "multiview")
    assert row["duration_s"] > 1.5  # 100 frames at 60 fps, on the audio clock
    clip = Dataset(out).load(row["clip_id"])
    # the stored 3D pose is the multi-view lifter's result on the same (repaired) detections
    cams = load_cameras(find_calibration(demo))
    ordered = match_videos(cams, sorted((demo / "videos").glob("*.mp4")))
    poses = [
        repair_pose2d(extract_take(v, config, with_audio=False).tracked.pose, config=config.repair)[
            0
        ]
        for v in ordered
    ]
    lifted = MultiviewLifter.from_config(config).lift(TakeViews.of(poses, cams))
    expected, _ = repair_pose3d(lifted, config=config.repair)
    frames = np.searchsorted(expected.timestamps, clip.timestamps + clip.start_s - 1e-9)
    np.testing.assert_allclose(clip.pose3d.joints, expected.joints[frames], atol=1e-5)
    assert clip.mask.mean() > 0.9
    assert clip.audio.std(axis=0).min() > 0  # real sound from cam02's track, not silence
