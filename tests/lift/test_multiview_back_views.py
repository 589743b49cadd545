"""What each camera of the real Pose2Sim demo sees: cam01 and cam02 the person's chest, cam03 and
cam04 the back (checked on the frames by eye). A back view's nose and eyes are the detector's
guesses; and with two cameras a left/right swap of the hips can reproject well."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturebank.app.extract import extract_take
from gesturebank.camera_files import CameraGroup, load_cameras
from gesturebank.config import Config, MultiviewConfig
from gesturebank.datasets.takes import find_calibration
from gesturebank.lift import TakeViews
from gesturebank.lift.multiview.lifter import MultiviewLifter, match_videos
from gesturebank.lift.multiview.robust import FACE, TORSO, Views, facing, fix_swaps, unseen_face
from gesturebank.lift.multiview.triangulate import dlt
from gesturebank.poses import Pose2D
from gesturebank.robot.retarget import face_forward_fraction
from gesturebank.skeletons import COCO17

DEMO = "pose2sim/Demo_SinglePerson"
IDX = COCO17.index


@pytest.fixture(scope="module")
def demo(samples: Path) -> tuple[list[Pose2D], CameraGroup]:
    root = samples / DEMO
    cams = load_cameras(find_calibration(root))
    videos = match_videos(cams, sorted((root / "videos").glob("*.mp4")))
    full_rate = Config.model_validate({"video": {"max_fps": None}})  # the demo's 60 fps
    return [extract_take(v, full_rate, with_audio=False).tracked.pose for v in videos], cams


def test_the_torso_says_which_cameras_see_the_back(demo) -> None:
    poses, cams = demo
    pose = MultiviewLifter().lift(TakeViews.of(poses, cams))
    cos = facing(pose.joints[:, TORSO].astype(np.float64), np.stack([c.center for c in cams]))
    back = np.nanmean(cos < MultiviewConfig().back_view_cos, axis=1)
    # measured: 0, 0, 0.96, 0.98 (cam03 sees the chest for a few frames as the person turns)
    np.testing.assert_array_less([-1, -1, 0.9, 0.9], back)
    np.testing.assert_array_less(back, [0.05, 0.05, 1.01, 1.01])


def test_a_back_views_face_is_ignored_and_the_head_faces_forward(demo) -> None:
    poses, cams = demo
    views = TakeViews.of(poses, cams)
    kept = MultiviewLifter(multiview=MultiviewConfig(back_view_cos=None)).lift(views)
    dropped = MultiviewLifter().lift(views)
    # the face (mid-ears → nose) in front of the torso: measured 0.88 → 0.94
    assert face_forward_fraction(dropped) > face_forward_fraction(kept) + 0.03
    assert face_forward_fraction(dropped) > 0.9


def test_a_face_only_back_views_saw_is_kept() -> None:
    """Two cameras, one seeing the back: its guess is all there is for the nose (kept); with two
    cameras facing the person as well, it goes."""
    conf = np.ones((3, 1, 17))
    back = np.array([[True], [False], [False]])
    drop = unseen_face(conf, back, min_confidence=0.3, min_cameras=2)
    assert drop[0, 0, FACE].all() and not drop[1:].any() and drop.sum() == len(FACE)
    two = unseen_face(conf[:2], back[:2], min_confidence=0.3, min_cameras=2)
    assert not two.any()


def test_two_cameras_keep_the_hips_apart(demo) -> None:
    """cam01 + cam02 alone: cam02 swaps the hips in some frames (a person seen from the front,
    legs crossing), and the two epipolar lines run through both hips, so the swapped pair
    reprojects well but lands ~40 cm apart. The width check puts the labels back."""
    poses, cams = demo
    pair = cams.subset(["cam01", "cam02"])
    views = Views.of(
        np.stack([p.to_coco17().keypoints for p in poses[:2]]), pair, min_confidence=0.3
    )

    def hip_width_cv(width_dev: float | None) -> float:
        swapped = fix_swaps(views, max_error_px=12.0, max_width_dev=width_dev)
        v = views.relabel(swapped)
        hips = [dlt(v.normalised[:, :, j], v.extrinsics, weights=v.weights[:, :, j]) for j in
                (IDX["left_hip"], IDX["right_hip"])]  # fmt: skip
        width = np.linalg.norm(hips[0] - hips[1], axis=-1)
        return float(np.nanstd(width) / np.nanmean(width))

    before, after = hip_width_cv(None), hip_width_cv(MultiviewConfig().max_bone_dev)
    print(f"\ncam01+cam02 hip width CV {before:.3f} → {after:.3f}")
    assert after < 0.6 * before
    assert after < 0.15
