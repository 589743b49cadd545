"""Detector registry (built-ins, entry-point plug-ins, the constructor convention), mediapipe and
blazepose on real media, openpose-json."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from fractions import Fraction
from pathlib import Path

import av
import numpy as np
import pytest

from gesturebank.app.extract import detect_people, extract_take
from gesturebank.config import (
    Config,
    DetectorConfig,
    MediaPipeConfig,
    OpenPoseJsonConfig,
    VideoConfig,
)
from gesturebank.errors import ConfigError, DetectionError, InputError
from gesturebank.extract.cache import DetectionCache
from gesturebank.extract.detectors import DETECTORS
from gesturebank.extract.detectors.openpose_json import read_openpose_folder
from gesturebank.extract.video import iter_frames
from gesturebank.poses import MultiPose2D
from gesturebank.skeletons import BLAZEPOSE33, COCO17, OPENPOSE_BODY25, get_skeleton

# ---------------------------------------------------------------- registry and plug-ins


def test_builtins_are_registered_without_importing_mediapipe() -> None:
    code = (
        "import sys, gesturebank\n"
        "from gesturebank.extract.detectors import DETECTORS\n"
        "names = DETECTORS.names()\n"
        "assert {'blazepose', 'mediapipe', 'openpose-json'} <= set(names), names\n"
        "assert 'mediapipe' not in sys.modules and 'ai_edge_litert' not in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_every_builtin_takes_config_video_and_threads(tmp_path: Path) -> None:
    """One constructor convention: (config, *, video, threads)."""
    video = tmp_path / "grey.mp4"
    write_grey_video(video, n=2)
    (tmp_path / "grey_json").mkdir()
    for name in ("blazepose", "mediapipe", "openpose-json"):
        det = DETECTORS.create(name, DetectorConfig().settings(name), video=video, threads=1)
        assert det.name == name


PLUGIN = '''
import numpy as np
from gesturebank.poses import Pose2D

class CornerDetector:
    """Puts one COCO-17 person in the top-left corner of every frame."""

    name = "corner"

    def __init__(self, config=None, *, video=None):
        self.config = config

    def detect(self, frames):
        times, size = [], None
        for t, image in frames:
            times.append(t)
            size = (image.shape[1], image.shape[0])
        one = np.linspace(0.05, 1, 17 * 3, dtype=np.float32).reshape(17, 3)
        kp = np.tile(one * [10, 10, 1], (len(times), 1, 1))
        return Pose2D(kp, np.array(times), "coco17", size)
'''


@pytest.fixture
def plugin(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    """A third-party distribution declaring a detector in the entry-point group."""
    (tmp_path / "corner_detector.py").write_text(textwrap.dedent(PLUGIN))
    dist = tmp_path / "corner_detector-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: corner-detector\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text(
        "[gesturebank.detectors]\ncorner = corner_detector:CornerDetector\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    yield "corner"
    DETECTORS._factories.pop("corner", None)  # forget the loaded plug-in
    sys.modules.pop("corner_detector", None)


def write_grey_video(path: Path, n: int = 5, size: tuple[int, int] = (64, 48)) -> None:
    w, h = size
    with av.open(str(path), "w") as out:
        s = out.add_stream("libx264", rate=25)
        s.width, s.height, s.pix_fmt = w, h, "yuv420p"
        for i in range(n):
            f = av.VideoFrame.from_ndarray(np.full((h, w, 3), 100, np.uint8), "rgb24")
            f.pts, f.time_base = i, Fraction(1, 25)
            out.mux(s.encode(f))
        out.mux(s.encode())


def test_entry_point_plugin_is_found_and_used(plugin: str, tmp_path: Path) -> None:
    assert plugin in DETECTORS.names()
    video = tmp_path / "grey.mp4"
    write_grey_video(video, n=5)
    config = Config()
    config.detector.name = plugin
    ex = extract_take(video, config, cache=DetectionCache(tmp_path / "cache"))
    pose = ex.tracked.pose
    assert ex.info.detector == "corner" and ex.audio is None
    assert pose.skeleton == "coco17" and pose.keypoints.shape == (5, 17, 3)
    np.testing.assert_allclose(pose.timestamps, np.arange(5) / 25)
    assert pose.image_size == (64, 48)


def test_unknown_detector_lists_the_known_ones() -> None:
    with pytest.raises(InputError, match="mediapipe"):
        DETECTORS.get("no-such-detector")


# ---------------------------------------------------------------- mediapipe guards


@pytest.mark.parametrize("complexity", [0, 2])
def test_unbundled_model_is_refused_before_mediapipe_runs(
    complexity: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    from mediapipe.python.solutions import pose as mp_pose

    def forbidden(*args: object, **kwargs: object) -> None:
        raise AssertionError("mediapipe Pose constructed: it would try a download")

    monkeypatch.setattr(mp_pose, "Pose", forbidden)
    with pytest.raises(ConfigError) as err:
        DETECTORS.create("mediapipe", MediaPipeConfig(model_complexity=complexity))
    msg = str(err.value)
    assert f"model_complexity={complexity}" in msg and "pip install --no-deps mediapipe" in msg


def test_missing_mediapipe_says_how_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name == "mediapipe" else real(name, *a),
    )
    with pytest.raises(DetectionError) as err:
        DETECTORS.create("mediapipe", MediaPipeConfig())
    assert "pip install --no-deps mediapipe==0.10.14" in str(err.value)
    assert "protobuf>=4.25.3,<5" in str(err.value)


# ---------------------------------------------------------------- mediapipe on real media


def plausible(kp: np.ndarray, skeleton: str, min_conf: float = 0.5) -> np.ndarray:
    """(T,) bool: shoulders above hips, and elbow and wrist within arm reach.

    Body proportions: upper arm and forearm are each ~0.6 of the shoulder-to-hip (torso) length
    in 3D, never longer than it; allowing 0.9 leaves room for perspective. Upright people have
    both shoulders higher in the image (smaller y) than both hips. Frames with low confidence on
    the joints of a check pass that check (nothing to check).
    """
    c = get_skeleton(skeleton).convert(kp, COCO17)
    j = COCO17.index
    conf = c[..., 2]
    sh = [j["left_shoulder"], j["right_shoulder"]]
    hp = [j["left_hip"], j["right_hip"]]
    sure = (conf[:, sh + hp] > min_conf).all(axis=1)
    ok = ~sure | (c[:, sh, 1].max(axis=1) < c[:, hp, 1].min(axis=1))
    torso = np.linalg.norm(c[:, sh, :2].mean(axis=1) - c[:, hp, :2].mean(axis=1), axis=1)
    for side in ("left", "right"):
        s, e, w = (j[f"{side}_{n}"] for n in ("shoulder", "elbow", "wrist"))
        sure = (conf[:, [s, e, w, *sh, *hp]] > min_conf).all(axis=1)
        upper = np.linalg.norm(c[:, e, :2] - c[:, s, :2], axis=1)
        fore = np.linalg.norm(c[:, w, :2] - c[:, e, :2], axis=1)
        ok &= ~sure | ((upper < 0.9 * torso) & (fore < 0.9 * torso))
    return ok


@pytest.fixture(scope="module")
def cam01_pose(samples: Path):
    det = DETECTORS.create("mediapipe", MediaPipeConfig())
    video = samples / "pose2sim" / "Demo_SinglePerson" / "videos" / "cam01.mp4"
    return det.detect(iter_frames(video, VideoConfig(max_fps=None)))  # all 100 frames


def test_mediapipe_finds_the_person_on_pose2sim_cam01(cam01_pose) -> None:
    pose = cam01_pose
    assert pose.skeleton == BLAZEPOSE33.name and pose.keypoints.shape == (100, 33, 3)
    assert pose.image_size == (1080, 1920)
    np.testing.assert_allclose(pose.timestamps, np.arange(100) / 60, atol=1e-6)
    found = np.isfinite(pose.keypoints[..., 0]).any(axis=1)
    assert found.mean() >= 0.95  # the subject is visible in every frame
    assert plausible(pose.keypoints[found], pose.skeleton).mean() >= 0.95
    # The person stands inside the image (portrait 1080 x 1920).
    hips = pose.to_coco17().keypoints[found][:, [11, 12], :2]
    assert np.all((hips[..., 0] > 0) & (hips[..., 0] < 1080))
    assert np.all((hips[..., 1] > 0) & (hips[..., 1] < 1920))
    # World landmarks come along for the learned lifter: metres, hips-centred.
    assert pose.world is not None and pose.world.shape == pose.keypoints.shape
    shoulder_w = np.linalg.norm(pose.world[found, 11] - pose.world[found, 12], axis=-1)
    assert 0.2 < np.median(shoulder_w) < 0.6


def sports2d_people(samples: Path, base: Path) -> MultiPose2D:
    """Everybody on the Sports2D demo with the default detector (blazepose) through the
    pipeline, cached in the session's temp dir."""
    found = detect_people(
        samples / "sports2d" / "Demo" / "demo.mp4",
        Config(),
        cache=DetectionCache(base / "detections"),
    )
    assert found.detector == "blazepose"
    return found.multi


def test_blazepose_finds_both_people_on_sports2d(samples: Path, tmp_path_factory) -> None:
    multi = sports2d_people(samples, tmp_path_factory.getbasetemp())
    assert multi.keypoints.shape[0] == 230 and multi.image_size == (1768, 994)
    assert multi.ids is not None and multi.world is not None
    anyone = multi.present.any(axis=1)
    assert anyone.mean() >= 0.95  # somebody is visible in every frame of the demo
    assert (multi.present.sum(axis=1) >= 2).sum() >= 120  # both, while the woman walks past
    kp = multi.keypoints[multi.present]
    assert plausible(kp, multi.skeleton).mean() >= 0.9  # he jumps and flips: some are upside down


# ---------------------------------------------------------------- openpose-json


def write_openpose(folder: Path, frames: list[np.ndarray], stem: str = "cam") -> None:
    """Per-frame JSON as OpenPose writes it: (0, 0, 0) for keypoints it did not find."""
    folder.mkdir(parents=True, exist_ok=True)
    for i, people in enumerate(frames):
        out = []
        for person in people:
            p = np.nan_to_num(np.asarray(person, np.float64), nan=0.0)
            out.append({"person_id": [-1], "pose_keypoints_2d": p.reshape(-1).tolist()})
        doc = {"version": 1.3, "people": out}
        (folder / f"{stem}_{i:012d}_keypoints.json").write_text(json.dumps(doc))


@pytest.mark.parametrize(("k", "skeleton"), [(25, "body25"), (18, "coco18"), (26, "halpe26")])
def test_openpose_json_skeleton_from_count_and_zeros_as_nan(
    tmp_path: Path, k: int, skeleton: str
) -> None:
    rng = np.random.default_rng(k)
    a = np.column_stack([rng.uniform(10, 90, (k, 2)), rng.uniform(0.3, 1, k)])
    b = a + np.array([5, 5, 0])
    a[3] = 0  # not found by OpenPose
    write_openpose(tmp_path / "kp", [[a, b], [b], []])
    multi = read_openpose_folder(tmp_path / "kp", fps=25, image_size=(100, 100))
    assert multi.skeleton == skeleton and multi.keypoints.shape == (3, 2, k, 3)
    np.testing.assert_allclose(multi.timestamps, [0, 0.04, 0.08])
    assert np.isnan(multi.keypoints[0, 0, 3]).all()
    np.testing.assert_allclose(multi.keypoints[0, 1], b, rtol=1e-6)
    assert multi.present.tolist() == [[True, True], [True, False], [False, False]]


def test_openpose_json_frame_order_is_numeric_and_video_clock_is_used(tmp_path: Path) -> None:
    k = 18
    frames = [np.full((1, k, 3), i + 1.0) for i in range(12)]  # frame i at x = y = i + 1
    folder = tmp_path / "take_json"
    folder.mkdir()
    for i, f in enumerate(frames):  # unpadded numbers: 'f10' must sort after 'f9'
        kp = f[0].copy()
        kp[:, 2] = 1.7  # rtmlib's SimCC scores can exceed 1: clipped to [0, 1] on reading
        doc = {"people": [{"pose_keypoints_2d": kp.reshape(-1).tolist()}]}
        (folder / f"take_f{i}.json").write_text(json.dumps(doc))
    video = tmp_path / "take.mp4"
    write_grey_video(video, n=12)
    det = DETECTORS.create("openpose-json", OpenPoseJsonConfig(), video=video)
    multi = det.detect_people()
    np.testing.assert_allclose(multi.keypoints[:, 0, 0, 0], np.arange(1, 13))
    assert np.all(multi.keypoints[..., 2] == 1.0)
    np.testing.assert_allclose(multi.timestamps, np.arange(12) / 25)
    assert multi.image_size == (64, 48)
    pose = det.detect()
    assert pose.skeleton == "coco18" and len(pose) == 12


def test_openpose_json_bad_file_is_named(tmp_path: Path) -> None:
    folder = tmp_path / "kp"
    write_openpose(folder, [[np.ones((25, 3))]])
    bad = folder / "cam_000000000001_keypoints.json"
    bad.write_text("{not json")
    with pytest.raises(InputError, match=str(bad)):
        read_openpose_folder(folder, fps=30, image_size=(10, 10))
    with pytest.raises(InputError, match="keypoint folder not found"):
        read_openpose_folder(tmp_path / "missing", fps=30)
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="no OpenPose-format"):
        read_openpose_folder(tmp_path / "empty", fps=30)


def test_openpose_json_from_real_two_person_detections(
    samples: Path, tmp_path: Path, tmp_path_factory
) -> None:
    """Real blazepose detections of both Sports2D people, written as BODY_25 OpenPose JSON
    beside a copy of the video, come back through the openpose-json detector unchanged."""
    video = samples / "sports2d" / "Demo" / "demo.mp4"
    multi = sports2d_people(samples, tmp_path_factory.getbasetemp())
    body25 = BLAZEPOSE33.convert(multi.keypoints, OPENPOSE_BODY25)
    frames = [[p for p in body25[t] if np.isfinite(p[:, 0]).any()] for t in range(len(body25))]
    copy = tmp_path / "demo.mp4"
    copy.symlink_to(video)
    write_openpose(tmp_path / "demo_json", frames, stem="demo")
    config = Config()
    config.detector.name = "openpose-json"
    found = detect_people(copy, config, cache=DetectionCache(tmp_path / "c"))
    back, name, hit = found.multi, found.detector, found.cache_hit
    assert name == "openpose-json" and hit is None  # JSON is read, never cached
    assert back.skeleton == "body25" and len(back) == 230
    np.testing.assert_allclose(back.timestamps, np.arange(230) / 30, atol=1e-6)
    assert back.present.sum() == multi.present.sum()
    mask = back.present
    ref = body25[multi.present]
    np.testing.assert_allclose(
        np.sort(back.keypoints[mask][..., 0], axis=None),
        np.sort(ref[..., 0], axis=None),
        rtol=1e-5,
    )
