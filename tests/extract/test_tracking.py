"""Identity tracking and main-speaker choice: synthetic scenes, then the real Sports2D demo."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturebank.config import Config, TrackingConfig
from gesturebank.errors import DetectionError
from gesturebank.extract.cache import DetectionCache
from gesturebank.extract.detectors import MultiPose2D
from gesturebank.extract.pipeline import detect_people, extract_take
from gesturebank.extract.tracking import find_switches, link, main_speaker
from gesturebank.skeletons import COCO17

SIZE_S2D = (1768, 994)
SIZE = (1000, 600)  # image diagonal ≈ 1166 px; the default gate 0.25 ≈ 292 px
FPS = 30.0

# A standing person in COCO-17 order, unit = body height, origin between the hips.
_BODY = {
    "nose": (0, -0.85),
    "left_eye": (0.03, -0.88),
    "right_eye": (-0.03, -0.88),
    "left_ear": (0.06, -0.86),
    "right_ear": (-0.06, -0.86),
    "left_shoulder": (0.12, -0.7),
    "right_shoulder": (-0.12, -0.7),
    "left_elbow": (0.15, -0.45),
    "right_elbow": (-0.15, -0.45),
    "left_wrist": (0.16, -0.2),
    "right_wrist": (-0.16, -0.2),
    "left_hip": (0.08, 0.0),
    "right_hip": (-0.08, 0.0),
    "left_knee": (0.08, 0.25),
    "right_knee": (-0.08, 0.25),
    "left_ankle": (0.08, 0.5),
    "right_ankle": (-0.08, 0.5),
}
TEMPLATE = np.array([_BODY[j] for j in COCO17.joints])


def person(x: float, y: float, height: float = 300, conf: float = 0.9, arms_up: bool = False):
    """(17, 3) keypoints of a person whose hips are at (x, y)."""
    xy = TEMPLATE.copy()
    if arms_up:
        xy[[7, 8, 9, 10], 1] = [-0.95, -0.95, -1.2, -1.2]
    kp = np.column_stack([xy * height + [x, y], np.full(17, conf)])
    return kp.astype(np.float32)


def scene(frames: list[list[np.ndarray]], shuffle: int | None = None) -> MultiPose2D:
    """Pack per-frame people; `shuffle` seeds a random slot order per frame (slots mean nothing)."""
    rng = np.random.default_rng(shuffle)
    packed = []
    for people in frames:
        arr = np.stack(people) if people else np.zeros((0, 17, 3), np.float32)
        if shuffle is not None and len(arr) > 1:
            arr = arr[rng.permutation(len(arr))]
        packed.append(arr)
    ts = np.arange(len(frames)) / FPS
    return MultiPose2D.from_people(packed, ts, "coco17", SIZE)


def track_of(multi: MultiPose2D, ids: np.ndarray, pred) -> np.ndarray:
    """(T,) id of the slot whose mid-hip x satisfies `pred(x, t)`; -1 if none."""
    out = np.full(len(multi), -1)
    for t in range(len(multi)):
        for p in np.flatnonzero(multi.present[t]):
            if pred(multi.keypoints[t, p, 11:13, 0].mean(), t):
                out[t] = ids[t, p]
    return out


@pytest.mark.parametrize("same_shape", [False, True])
def test_people_crossing_keep_their_identity(same_shape: bool) -> None:
    n = 41
    xs = np.linspace(200, 800, n)
    frames = [
        [person(xs[t], 450), person(xs[::-1][t] + 3, 450, arms_up=not same_shape)] for t in range(n)
    ]
    multi = scene(frames, shuffle=3)
    ids = link(multi, gate=0.25)
    a = track_of(multi, ids, lambda x, t: abs(x - xs[t]) < 1)
    b = track_of(multi, ids, lambda x, t: abs(x - xs[::-1][t] - 3) < 1)
    assert len(set(a)) == 1 and len(set(b)) == 1 and a[0] != b[0]
    assert find_switches(multi.timestamps, ids) == ()


def test_person_leaving_and_another_entering() -> None:
    frames = []
    for t in range(150):
        people = [person(300, 450)]
        if t < 20:
            people.append(person(800 + 5 * t, 450))  # walks out to the right
        if t >= 100:
            people.append(person(100, 450, height=200))  # someone new, 2.7 s later
        frames.append(people)
    multi = scene(frames, shuffle=1)
    ids = link(multi, gate=0.25)
    stay = track_of(multi, ids, lambda x, t: abs(x - 300) < 1)
    assert len(set(stay)) == 1
    assert len(np.unique(ids[ids >= 0])) == 3
    assert find_switches(multi.timestamps, ids) == ()  # leaving and entering are not switches


def test_jump_beyond_gate_starts_a_new_identity_and_is_reported() -> None:
    # One detection per frame, as a single-person detector gives: it jumps to someone else.
    frames = [[person(200, 450)] for _ in range(10)] + [[person(800, 450)] for _ in range(10)]
    multi = scene(frames)
    ids = link(multi, gate=0.25)  # 600 px > 292 px
    assert len(set(ids[:10, 0])) == 1 and len(set(ids[10:, 0])) == 1 and ids[0, 0] != ids[10, 0]
    switches = find_switches(multi.timestamps, ids)
    assert len(switches) == 1
    assert switches[0].timestamp == pytest.approx(10 / FPS)
    assert (switches[0].old_id, switches[0].new_id) == (ids[0, 0], ids[10, 0])
    # A generous gate keeps one identity.
    assert len(set(link(multi, gate=0.6)[:, 0])) == 1


def test_small_moves_within_the_gate_keep_the_identity() -> None:
    rng = np.random.default_rng(0)
    frames = [[person(500 + 20 * np.sin(t / 5), 450 + rng.normal(0, 3))] for t in range(60)]
    assert len(set(link(scene(frames))[:, 0])) == 1


def test_main_speaker_is_large_central_and_present() -> None:
    frames = []
    for t in range(60):
        people = [person(500, 500, height=400), person(900, 300, height=150)]
        if 20 <= t < 30:  # a passer-by: central, large, but only briefly
            people.append(person(520, 560, height=450))
        frames.append(people)
    multi = scene(frames, shuffle=5)
    tracked = main_speaker(multi)
    hips = tracked.pose.keypoints[:, 11:13, 0].mean(axis=1)
    assert np.all(np.abs(hips - 500) < 1)  # always the big central speaker
    assert tracked.report.main_coverage == 1.0 and tracked.report.n_tracks == 3


def test_tracking_weights_change_the_choice() -> None:
    frames = [[person(500, 500, height=400, conf=0.4), person(900, 300, 150, conf=1.0)]] * 30
    multi = scene(frames)
    by_size = main_speaker(multi, TrackingConfig())
    by_conf = main_speaker(
        multi, TrackingConfig(size_weight=0, center_weight=0, confidence_weight=1)
    )
    assert by_size.pose.keypoints[0, 11, 0] == pytest.approx(500 + 0.08 * 400)
    assert by_conf.pose.keypoints[0, 11, 0] == pytest.approx(900 + 0.08 * 150)


def test_nobody_in_any_frame_is_a_detection_error() -> None:
    with pytest.raises(DetectionError, match="clip.mp4"):
        main_speaker(scene([[] for _ in range(5)]), source="clip.mp4")


# ---------------------------------------------------------------- the real Sports2D demo

# Hand-annotated from the frames themselves (torso centre, full-resolution pixels): the man on
# the box, who jumps off at ~5.7 s and lands to the right; the woman walks right to left.
MAN = {60: (630, 240), 120: (720, 240), 150: (790, 220), 200: (1150, 790)}
WOMAN = {60: (1424, 690), 120: (830, 660), 150: (520, 660), 180: (200, 710)}


def _torso(kp: np.ndarray) -> np.ndarray:
    """(2,) mean of shoulders and hips of a (33, 3) BlazePose person."""
    return np.nanmean(kp[[11, 12, 23, 24], :2], axis=0)


@pytest.fixture(scope="module")
def sports2d(samples: Path, tmp_path_factory) -> tuple[Path, MultiPose2D, DetectionCache]:
    video = samples / "sports2d" / "Demo" / "demo.mp4"
    cache = DetectionCache(tmp_path_factory.getbasetemp() / "detections")  # shared with detectors
    multi, _, _ = detect_people(video, Config(), cache=cache, max_people=2)
    return video, multi, cache


def test_sports2d_main_speaker_keeps_one_identity(sports2d) -> None:
    video, multi, cache = sports2d
    pose, _, info = extract_take(video, Config(), cache=cache, max_people=2)
    assert info.cache_hit is True  # detect_people above stored the same entry
    report = info.tracking
    assert report.main_switches == ()
    kp = pose.keypoints
    for frame, where in MAN.items():
        assert np.isfinite(kp[frame, :, 0]).any(), f"main speaker missing at frame {frame}"
        assert np.linalg.norm(_torso(kp[frame]) - where) < 120, frame
    for frame, where in WOMAN.items():
        if np.isfinite(kp[frame, :, 0]).any():
            assert np.linalg.norm(_torso(kp[frame]) - where) > 300, frame
    # The woman is tracked too, as one other identity while she walks past.
    ids = link(multi, TrackingConfig().gate)
    others = {int(ids[t, p]) for t in WOMAN for p in range(ids.shape[1])} - {report.main_id, -1}
    assert len(others) == 1


def test_single_person_detector_jump_is_reported_as_a_switch(sports2d) -> None:
    """BlazePose alone follows the woman while the man flips (slot 0 is the BlazePose that sees
    the unmasked frames, i.e. what the single-person detector gives). Tracking reports the jump
    as a switch and still outputs only the man."""
    _, multi, _ = sports2d
    single = MultiPose2D(multi.keypoints[:, :1], multi.timestamps, multi.skeleton, SIZE_S2D)
    assert np.linalg.norm(_torso(single.keypoints[180, 0]) - WOMAN[180]) < 120
    tracked = main_speaker(single)
    assert len(tracked.report.main_switches) >= 1
    kp = tracked.pose.keypoints
    for frame, where in MAN.items():
        if np.isfinite(kp[frame, :, 0]).any():
            assert np.linalg.norm(_torso(kp[frame]) - where) < 120
    assert not np.isfinite(kp[180, :, 0]).any()  # the woman's frames are not passed off as his
