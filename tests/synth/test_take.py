"""A rendered take: its folder is what build-dataset reads, its truth is the BVH's own motion,
its cameras round-trip and project the truth, it has speech, and it is rendered once."""

from __future__ import annotations

from pathlib import Path

import av
import numpy as np
import pytest

from gesturebank.camera_files import load_cameras
from gesturebank.config import MocapConfig, SynthConfig
from gesturebank.datasets.takes import discover_takes
from gesturebank.mocap.bvh import read_bvh
from gesturebank.mocap.pose import motion_pose
from gesturebank.robot.pepper import JOINTS
from gesturebank.synth.camera import Stage, orbit_camera, stage_of
from gesturebank.synth.figure import head_frame
from gesturebank.synth.looks import LOOKS
from gesturebank.synth.raycast import Figure, render_frames
from gesturebank.synth.take import Performer, cached_render, render_take, rig_azimuths
from gesturebank.synth.truth import Truth
from tests.synth.conftest import START_S

pytestmark = pytest.mark.media

RIG = SynthConfig(
    azimuths_deg=[-30.0, 30.0],
    width_px=320,
    height_px=180,
    start_s=START_S,
    length_s=0.5,
    look="sleeves",
)


@pytest.fixture(scope="module")
def rig(test_bvh: Path, speech: list[Path], tmp_path_factory: pytest.TempPathFactory) -> Truth:
    cache = tmp_path_factory.mktemp("synth")
    return cached_render(
        [Performer(test_bvh)], config=RIG, mocap=MocapConfig(), speech=speech, cache=cache
    )


def test_truth_is_the_bvh_motion_at_the_video_times(rig: Truth, test_bvh: Path) -> None:
    assert len(rig.times) == 15  # 0.5 s at 30 fps
    np.testing.assert_allclose(np.diff(rig.times), 1 / 30)
    pose, _ = motion_pose(read_bvh(test_bvh))
    first = round(START_S * 30)  # the file's frames are 0.033333 s apart: within 0.3 ms of ours
    np.testing.assert_allclose(rig.joints3d, pose.joints[first : first + 15], atol=1e-3)
    assert rig.angles.shape == (15, len(JOINTS)) and np.isfinite(rig.angles).all()
    assert rig.figures3d.shape == (1, 15, 17, 3) and rig.mouth.shape == (1, 15)


def test_calibration_round_trips_and_projects_the_truth(rig: Truth) -> None:
    cameras = load_cameras(rig.folder / "calibration.toml")
    assert cameras.names == ["cam01", "cam02"]
    for c, camera in enumerate(cameras):
        assert camera.size == (320, 180)
        np.testing.assert_allclose(camera.project(rig.joints3d), rig.joints2d[c], atol=1e-6)
        inside = (rig.joints2d[c] >= 0) & (rig.joints2d[c] < [320, 180])
        assert inside.all(), "the whole figure is in view"
    # the two cameras stand 60° apart around the figure, 3 m from it
    target = stage_of(rig.joints3d).target
    a, b = (camera.center - target for camera in cameras)
    assert np.degrees(np.arccos(a @ b / np.linalg.norm(a) / np.linalg.norm(b))) == pytest.approx(60)
    assert np.linalg.norm(a) == pytest.approx(3.0)


def test_the_folder_is_a_multi_camera_take_with_speech(rig: Truth) -> None:
    (take,) = discover_takes(rig.folder.parent)
    assert take.multi_camera and sorted(take.videos) == sorted(rig.videos)
    assert take.audio == rig.folder / "speech.wav"
    with av.open(str(rig.videos[0])) as video:
        frames = sum(1 for _ in video.decode(video.streams.video[0]))
    with av.open(str(rig.videos[0])) as video:
        samples = np.concatenate([f.to_ndarray().ravel() for f in video.decode(audio=0)])
    assert frames == 15
    assert np.sqrt(np.mean(samples**2)) > 0.01  # speech, not silence


def test_a_render_is_made_once(
    rig: Truth, test_bvh: Path, speech: list[Path], tmp_path: Path
) -> None:
    stamp = rig.videos[0].stat().st_mtime_ns
    again = cached_render(
        [Performer(test_bvh)],
        config=RIG,
        mocap=MocapConfig(),
        speech=speech,
        cache=rig.folder.parent,
    )
    assert again.folder == rig.folder and again.videos[0].stat().st_mtime_ns == stamp


def test_rig_azimuths_spread_around_the_first() -> None:
    assert rig_azimuths(centre_deg=10, count=3, spread_deg=90) == [-35.0, 10.0, 55.0]
    assert rig_azimuths(centre_deg=10, count=1, spread_deg=90) == [10.0]


def test_the_mouth_opens(stretch_joints: np.ndarray) -> None:
    joints = stretch_joints[:1]
    centre, axes = head_frame(joints)
    face = Stage(target=centre[0], forward=axes[0, 0], up=stage_of(joints).up)
    close = orbit_camera(  # 0.6 m in front of the face
        face, name="c", azimuth_deg=0, elevation_deg=0, distance_m=0.6, fov_deg=30, size=(160, 160)
    )
    mouth_at = centre[0] + np.array([0.1, -0.067, 0.0]) @ axes[0]  # forward, up, left
    u, v = np.round(close.project(mouth_at)).astype(int)
    look = LOOKS["tshirt"]
    shut, wide = (
        next(
            render_frames([Figure(joints, np.array([m]), look)], close, scenery=look, supersample=1)
        )
        for m in (0.0, 1.0)
    )
    assert (
        wide[v - 2 : v + 3, u - 4 : u + 5].mean() < 0.6 * shut[v - 2 : v + 3, u - 4 : u + 5].mean()
    )


def test_two_performers_stand_where_they_are_put(
    test_bvh: Path, speech: list[Path], tmp_path: Path
) -> None:
    config = SynthConfig(width_px=320, height_px=180, start_s=START_S, length_s=0.1)
    mouth = np.linspace(0, 1, 3)
    truth = render_take(
        [Performer(test_bvh), Performer(test_bvh, offset_m=(0.0, 1.2, 0.0), mouth=mouth)],
        tmp_path,
        config=config,
        mocap=MocapConfig(),
        speech=speech,
    )
    first, second = truth.figures3d
    np.testing.assert_array_equal(first, truth.joints3d)
    shift = second - first
    np.testing.assert_allclose(shift, np.broadcast_to(shift[0, 0], shift.shape), atol=1e-9)
    assert np.linalg.norm(shift[0, 0]) == pytest.approx(1.2)
    np.testing.assert_allclose(truth.mouth, [np.zeros(3), mouth])
    # the second figure stands to the first one's left: on the right of the picture
    seen = truth.cameras[0].project(second)
    assert (seen[..., 0] > truth.joints2d[0][..., 0].max()).mean() > 0.5
