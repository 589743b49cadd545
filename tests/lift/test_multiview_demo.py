"""The multiview lifter on the real Pose2Sim Demo_SinglePerson: 4 cameras, its own Qualisys
calibration, BlazePose 2D from the project's detector."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from gesturebank.app.extract import extract_take
from gesturebank.camera_files import CameraGroup, load_cameras, save_cameras
from gesturebank.config import Config, MultiviewConfig
from gesturebank.datasets.takes import find_calibration
from gesturebank.errors import CalibrationError, InputError
from gesturebank.lift import TakeViews
from gesturebank.lift.multiview.lifter import MultiviewLifter, match_cameras, match_videos
from gesturebank.poses import Pose2D
from gesturebank.skeletons import COCO17

DEMO = "pose2sim/Demo_SinglePerson"
UPPER = [
    "nose", "left_eye", "right_eye", "left_ear", "right_ear", "left_shoulder", "right_shoulder",
    "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_hip", "right_hip",
]  # fmt: skip
UPPER_IDX = [COCO17.index[j] for j in UPPER]


@pytest.fixture(scope="session")
def demo(samples: Path) -> tuple[list[Pose2D], CameraGroup]:
    """Detections (cached on disk after the first run) and the cameras, in camera order."""
    root = samples / DEMO
    cams = load_cameras(find_calibration(root))
    videos = match_videos(cams, sorted((root / "videos").glob("*.mp4")))
    full_rate = Config.model_validate({"video": {"max_fps": None}})  # the demo's 60 fps
    return [extract_take(v, full_rate, with_audio=False).tracked.pose for v in videos], cams


def raw_reprojection(
    joints: np.ndarray,
    used: np.ndarray,
    poses: list[Pose2D],
    cams: CameraGroup,
    labels: np.ndarray | None = None,
) -> np.ndarray:
    """(T, 17) mean pixel distance, over the cameras used, between the detector's raw 2D
    keypoints and OpenCV's projection of the 3D joints (independent of the lifter's maths).
    labels (C, T, 17): the 2D joint each camera's joint was solved from (a repaired swap)."""
    T = joints.shape[0]
    total, n = np.zeros((T, 17)), np.zeros((T, 17))
    for c, (cam, pose) in enumerate(zip(cams, poses, strict=True)):
        ok = np.isfinite(joints).all(-1) & used[c]
        proj, _ = cv2.projectPoints(np.nan_to_num(joints).reshape(-1, 3), cam.rvec, cam.t, cam.K,
                                    cam.dist)  # fmt: skip
        xy = pose.to_coco17().xy
        if labels is not None:
            xy = np.take_along_axis(xy, labels[c][..., None], axis=1)
        err = np.linalg.norm(proj.reshape(T, 17, 2) - xy, axis=-1)
        total += np.where(ok, err, 0)
        n += ok
    with np.errstate(invalid="ignore"):
        return np.where(n > 0, total / n, np.nan)


def test_demo_reprojection_error(demo: tuple[list[Pose2D], CameraGroup]) -> None:
    poses, cams = demo
    pose3d, report = MultiviewLifter(multiview=MultiviewConfig()).lift_with_report(
        TakeViews.of(poses, cams)
    )
    everything = MultiviewConfig(max_error_px=1e6, reject_error_px=None)
    all_views, _ = MultiviewLifter(multiview=everything).lift_with_report(TakeViews.of(poses, cams))
    err = raw_reprojection(pose3d.joints, report.triangulation.used, poses, cams, report.labels)
    used_all = np.isfinite(all_views.joints).all(-1)[None] & np.stack(
        [(p.to_coco17().confidence >= 0.3) for p in poses]
    )
    err_all = raw_reprojection(all_views.joints, used_all, poses, cams)
    print("\njoint            median px  p90 px  cameras   (all views: median px)")
    for name, med, p90, ncam in report.joint_table():
        j = COCO17.index[name]
        print(
            f"{name:15s}  {med:8.1f}  {p90:6.1f}  {ncam:6.2f}    {np.nanmedian(err_all[:, j]):6.1f}"
        )
    upper = err[:, UPPER_IDX]
    all_upper = np.nanmedian(err_all[:, UPPER_IDX])
    print(f"upper body: median {np.nanmedian(upper):.1f} px (all views {all_upper:.1f} px); "
          f"camera usage {report.camera_usage()}")  # fmt: skip
    assert np.isfinite(upper).mean() > 0.95
    assert np.nanmedian(upper) <= 10.0
    # The calibration convention is right: even without excluding any camera the error is
    # small (a wrong axis convention gives 100+ px).
    assert np.nanmedian(err_all[:, UPPER_IDX]) <= 25.0
    # The lifter's own report agrees with the independent measurement.
    assert np.nanmedian(report.triangulation.error[:, UPPER_IDX]) == pytest.approx(
        np.nanmedian(upper), rel=0.05
    )


def test_demo_pose_is_a_person_in_metres(demo: tuple[list[Pose2D], CameraGroup]) -> None:
    poses, cams = demo
    pose3d = MultiviewLifter().lift(TakeViews.of(poses, cams))
    assert pose3d.units == "m" and pose3d.frame == "world" and len(pose3d) == 100
    np.testing.assert_array_equal(pose3d.timestamps, poses[0].timestamps)
    shoulders = np.linalg.norm(
        pose3d.joint("left_shoulder") - pose3d.joint("right_shoulder"), axis=-1
    )
    upper_arm = np.linalg.norm(pose3d.joint("left_shoulder") - pose3d.joint("left_elbow"), axis=-1)
    assert 0.25 < np.nanmedian(shoulders) < 0.50
    assert 0.22 < np.nanmedian(upper_arm) < 0.40
    # Bones keep their length from frame to frame in most frames (a rigid person, not noise).
    # A few frames are wrong where two cameras agree on a mislabelled elbow (a left/right swap
    # in one view): exclusion by reprojection error alone cannot see those.
    for bone in (upper_arm, shoulders):
        steady = np.abs(bone - np.nanmedian(bone)) < 0.05
        assert steady.mean() > 0.85
    conf = pose3d.confidence[np.isfinite(pose3d.confidence)]
    assert conf.size and conf.min() >= 0 and conf.max() <= 1


def test_demo_unsynchronised_camera_is_realigned(demo: tuple[list[Pose2D], CameraGroup]) -> None:
    """cam04 started 12 frames late: motion sync finds it and the error stays low."""
    poses, cams = demo
    drop = 12
    late = Pose2D(
        poses[3].keypoints[drop:],
        poses[3].timestamps[drop:] - poses[3].timestamps[drop],
        poses[3].skeleton,
        poses[3].image_size,
    )
    views = TakeViews.of([poses[0], poses[1], poses[2], late], cams)
    naive = MultiviewLifter(multiview=MultiviewConfig()).lift_with_report(views)[1]
    motion = MultiviewConfig(sync="motion")
    synced = MultiviewLifter(multiview=motion).lift_with_report(views)[1]
    found = synced.offsets_s[3] * 60
    print(f"\ncam04 offset found {found:+.2f} frames (true {-drop}); median error "
          f"{np.nanmedian(naive.triangulation.error):.1f} px unsynced → "
          f"{np.nanmedian(synced.triangulation.error):.1f} px synced")  # fmt: skip
    assert synced.sync == ["reference", "motion", "motion", "motion"]
    assert abs(found + drop) <= 4  # cross-view motion sync is good to a few frames
    assert synced.camera_usage()["cam04"] > naive.camera_usage()["cam04"] + 0.1


def test_toml_calibration_gives_the_same_pose(
    demo: tuple[list[Pose2D], CameraGroup], tmp_path: Path
) -> None:
    poses, cams = demo
    path = tmp_path / "calibration.toml"
    save_cameras(cams, path)
    assert find_calibration(tmp_path) == path
    a = MultiviewLifter().lift(TakeViews.of(poses, cams)).joints
    b = MultiviewLifter().lift(TakeViews.of(poses, load_cameras(path))).joints
    np.testing.assert_allclose(a, b, atol=1e-5)


def test_take_folder_helpers(samples: Path, tmp_path: Path) -> None:
    root = samples / DEMO
    assert find_calibration(root).name == "Calib.qca.txt"
    cams = load_cameras(find_calibration(root))
    videos = match_videos(cams, sorted((root / "videos").glob("*.mp4"), reverse=True))
    assert [v.stem for v in videos] == ["cam01", "cam02", "cam03", "cam04"]
    with pytest.raises(CalibrationError, match="no calibration.toml"):
        find_calibration(tmp_path)
    with pytest.raises(CalibrationError, match="3 videos for 4"):
        match_videos(cams, [Path("a.mp4"), Path("b.mp4"), Path("c.mp4")])
    # a take with some of the calibrated cameras (a broken one left out): matched by name
    used, ordered = match_cameras(cams, [root / "videos/cam04.mp4", root / "videos/cam02.mp4"])
    assert used.names == ["cam02", "cam04"] and [v.stem for v in ordered] == ["cam02", "cam04"]
    with pytest.raises(CalibrationError, match="2 videos for 4"):
        match_cameras(cams, [Path("a.mp4"), Path("b.mp4")])


def test_bad_lifter_inputs(demo: tuple[list[Pose2D], CameraGroup]) -> None:
    poses, cams = demo
    with pytest.raises(InputError, match="two or more views"):
        MultiviewLifter().lift(TakeViews.of(poses[0], cams))
    with pytest.raises(InputError, match="3 views but 4 cameras"):
        MultiviewLifter().lift(TakeViews.of(poses[:3], cams))
    with pytest.raises(CalibrationError, match="no cameras"):
        MultiviewLifter().lift(TakeViews.of(poses))
    with pytest.raises(InputError, match="offsets_s"):
        two = MultiviewConfig(offsets_s=[0.0, 0.1])
        MultiviewLifter(multiview=two).lift(TakeViews.of(poses, cams))
