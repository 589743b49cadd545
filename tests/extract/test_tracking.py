"""Identities and the main-speaker choice: synthetic scenes (crossing, cuts, leaving, arriving),
then real detections — two real single-person tracks composited as two people, one of whose
motion drives the speech envelope — and the real Sports2D demo."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gesturebank.audio.io import Audio, read_audio
from gesturebank.config import BlazePoseConfig, TrackingConfig
from gesturebank.errors import DetectionError
from gesturebank.extract.detectors import DETECTORS
from gesturebank.extract.identity import find_switches, link, shot_index, split_at_cuts
from gesturebank.extract.tracking import TERMS, TrackReport, main_speaker
from gesturebank.extract.video import iter_frames
from gesturebank.poses import MultiPose2D, Pose2D
from gesturebank.skeletons import BLAZEPOSE33, COCO17

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


def hips_x(pose: Pose2D) -> np.ndarray:
    """(T,) mid-hip x of a COCO-17 pose (NaN where absent)."""
    return pose.keypoints[:, 11:13, 0].mean(axis=1)


@pytest.mark.parametrize("same_shape", [False, True])
def test_people_crossing_keep_their_identity(same_shape: bool) -> None:
    n = 41
    xs = np.linspace(200, 800, n)
    frames = [
        [person(xs[t], 450), person(xs[::-1][t] + 3, 450, arms_up=not same_shape)] for t in range(n)
    ]
    multi = scene(frames, shuffle=3)
    ids = link(multi, config=TrackingConfig())
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
    ids = link(multi, config=TrackingConfig())
    stay = track_of(multi, ids, lambda x, t: abs(x - 300) < 1)
    assert len(set(stay)) == 1
    assert len(np.unique(ids[ids >= 0])) == 3
    assert find_switches(multi.timestamps, ids) == ()  # leaving and entering are not switches


def test_jump_beyond_gate_starts_a_new_identity_and_is_reported() -> None:
    # One detection per frame, as a single-person detector gives: it jumps to someone else.
    frames = [[person(200, 450)] for _ in range(10)] + [[person(800, 450)] for _ in range(10)]
    multi = scene(frames)
    ids = link(multi, config=TrackingConfig())  # 600 px > 292 px
    assert len(set(ids[:10, 0])) == 1 and len(set(ids[10:, 0])) == 1 and ids[0, 0] != ids[10, 0]
    switches = find_switches(multi.timestamps, ids)
    assert len(switches) == 1
    assert switches[0].timestamp == pytest.approx(10 / FPS)
    assert (switches[0].old_id, switches[0].new_id) == (ids[0, 0], ids[10, 0])
    # A generous gate keeps one identity.
    assert len(set(link(multi, config=TrackingConfig(gate=0.6))[:, 0])) == 1


def test_small_moves_within_the_gate_keep_the_identity() -> None:
    rng = np.random.default_rng(0)
    frames = [[person(500 + 20 * np.sin(t / 5), 450 + rng.normal(0, 3))] for t in range(60)]
    assert len(set(link(scene(frames), config=TrackingConfig())[:, 0])) == 1


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


def test_a_passer_by_is_not_a_candidate() -> None:
    """Larger, more central and surer than the speaker, but seen in 15 % of the shot: even
    with persistence weighing nothing, a passer-by is not chosen (nor scored as a candidate)."""
    frames = []
    for t in range(100):
        people = [person(400, 500, height=300, conf=0.8)]
        if 40 <= t < 55:
            people.append(person(500, 420, height=450, conf=1.0))
        frames.append(people)
    tracked = main_speaker(scene(frames, shuffle=9), TrackingConfig(persistence_weight=0))
    (choice,) = tracked.report.choices
    assert np.allclose(hips_x(tracked.pose), 400)
    assert choice.runner_up is None and list(choice.scores) == [choice.main_id]
    passer = next(k for k in tracked.report.scores if k != choice.main_id)
    assert tracked.report.scores[passer] > tracked.report.scores[choice.main_id]


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


# ---------------------------------------------------------------- shots, leaving, arriving


def test_shot_index_puts_the_cut_frame_in_the_new_shot() -> None:
    ts = np.arange(10) / FPS
    shot = shot_index(timestamps=ts, cuts=np.array([ts[4], ts[7]]))
    assert shot.tolist() == [0, 0, 0, 0, 1, 1, 1, 2, 2, 2]
    assert shot_index(timestamps=ts, cuts=None).tolist() == [0] * 10


def test_split_at_cuts_gives_each_shot_its_own_identities() -> None:
    ids = np.array([[0, 1], [1, 0], [0, -1], [0, 1], [-1, 1]])
    shot = np.array([0, 0, 0, 1, 1])
    out = split_at_cuts(ids=ids, shot=shot)
    assert out.tolist() == [[0, 1], [1, 0], [0, -1], [2, 3], [-1, 3]]


def _two_shots(cut: int = 45, n: int = 90) -> list[list[np.ndarray]]:
    """Shot 1: a big central person at x=500 and a small one at x=850; shot 2 (from `cut`):
    the big one now stands at x=450 and the small one at x=880 — close enough that linking
    across the cut would carry each identity over."""
    frames = []
    for t in range(n):
        if t < cut:
            frames.append([person(500, 500, height=400), person(850, 300, height=150)])
        else:
            frames.append([person(880, 300, height=150), person(450, 520, height=420)])
    return frames


@pytest.mark.parametrize("detector_ids", [False, True])
def test_a_cut_rechooses_and_no_identity_spans_it(detector_ids: bool) -> None:
    multi = scene(_two_shots(), shuffle=2)
    if detector_ids:  # a tracking detector that knows nothing of cuts: one id per person
        big = multi.keypoints[:, :, 11, 1] > 400  # hips low in the image = the big person
        ids = np.where(big, 7, 3)
        multi = MultiPose2D(multi.keypoints, multi.timestamps, "coco17", SIZE, ids=ids)
    cut = multi.timestamps[45]
    tracked = main_speaker(multi, cuts=np.array([cut]))
    report, ids = tracked.report, tracked.ids
    shot = (multi.timestamps >= cut).astype(int)
    for k in np.unique(ids[ids >= 0]):
        assert len(set(shot[(ids == k).any(axis=1)])) == 1, f"identity {k} spans the cut"
    assert [(c.shot, c.reason) for c in report.choices] == [(0, "shot"), (1, "shot")]
    assert report.choices[0].end_s == report.choices[1].start_s == pytest.approx(cut)
    first, second = report.choices
    assert first.main_id != second.main_id
    assert report.main_ids[:45].tolist() == [first.main_id] * 45
    assert report.main_ids[45:].tolist() == [second.main_id] * 45
    x = hips_x(tracked.pose)
    assert np.allclose(x[:45], 500) and np.allclose(x[45:], 450)
    assert report.switches == ()  # every track ends at a cut: that is not an identity switch
    assert report.n_tracks == 4 and set(report.scores) == {0, 1, 2, 3}
    assert report.n_people.tolist() == [2] * 90


def test_chosen_person_leaving_mid_shot_hands_the_rest_of_the_shot_over() -> None:
    frames = []
    for t in range(180):  # 6 s; the big central person leaves after 3 s, for good
        people = [person(850, 300, height=150)]
        if t < 90:
            people.append(person(500, 500, height=400))
        frames.append(people)
    tracked = main_speaker(scene(frames, shuffle=4))
    first, second = tracked.report.choices
    assert (first.reason, second.reason) == ("shot", "left")
    assert first.start_s == 0 and second.start_s == pytest.approx(90 / FPS)
    assert first.runner_up == second.main_id and second.runner_up is None
    x = hips_x(tracked.pose)
    assert np.allclose(x[:90], 500) and np.allclose(x[90:], 850)
    assert tracked.report.main_id in (first.main_id, second.main_id)
    assert tracked.report.main_coverage == 1.0


def test_short_absence_keeps_the_choice() -> None:
    frames = []
    for t in range(180):  # the big central person is away for 1 s < max_lost_s = 2 s
        people = [person(850, 300, height=150)]
        if not 60 <= t < 90:
            people.append(person(500, 500, height=400))
        frames.append(people)
    tracked = main_speaker(scene(frames, shuffle=6))
    (only,) = tracked.report.choices
    assert set(tracked.report.main_ids.tolist()) == {only.main_id}
    x = hips_x(tracked.pose)
    assert np.isnan(x[60:90]).all()  # nobody else stands in for the main speaker
    assert np.allclose(x[:60], 500) and np.allclose(x[90:], 500)
    assert tracked.report.main_coverage == pytest.approx(150 / 180)


def test_late_arrival_leaves_the_frames_before_to_somebody_else() -> None:
    frames = []
    for t in range(300):  # 10 s; the big central person comes in at 3 s and stays
        people = [person(850, 300, height=150)]
        if t >= 90:
            people.append(person(500, 500, height=400))
        frames.append(people)
    tracked = main_speaker(scene(frames, shuffle=8))
    before, after = tracked.report.choices
    assert (before.reason, after.reason) == ("shot", "arrived")
    assert after.start_s == pytest.approx(3.0)
    x = hips_x(tracked.pose)
    assert np.allclose(x[:90], 850) and np.allclose(x[90:], 500)
    assert tracked.report.main_id == after.main_id  # the longest segment


def test_report_is_plain_json_and_reads_back() -> None:
    frames = [
        [person(850, 300, 150)] + ([person(500, 500, 400)] if t < 90 else []) for t in range(180)
    ]
    report = main_speaker(scene(frames)).report
    text = json.dumps(report.to_json_dict(), allow_nan=False)
    back = TrackReport.from_json_dict(json.loads(text))
    assert back.choices == report.choices and back.switches == report.switches
    assert back.scores == report.scores and back.main_id == report.main_id
    assert np.array_equal(back.main_ids, report.main_ids)
    assert np.array_equal(back.n_people, report.n_people)
    for choice in report.choices:
        for terms in choice.scores.values():
            assert set(terms) == {*TERMS, "total"}
            assert all(0.0 <= v <= 1.0 for v in terms.values())


# ------------------------------------------------------------------ real detections

# Hand-annotated from the frames themselves (torso centre, full-resolution pixels): the man on
# the box, who jumps off at ~5.7 s and lands to the right; the woman walks right to left.
MAN = {60: (630, 240), 120: (720, 240), 150: (790, 220), 200: (1150, 790)}
WOMAN = {60: (1424, 690), 120: (830, 660), 150: (520, 660), 180: (200, 710)}
CANVAS = (1920, 1080)
LEAD_S = 0.15  # the synthetic speech follows the gesturer's hands this much later


def _torso(kp: np.ndarray) -> np.ndarray:
    """(2,) mean of shoulders and hips of a (33, 3) BlazePose person."""
    return np.nanmean(kp[[11, 12, 23, 24], :2], axis=0)


def _place(kp: np.ndarray, shoulder_px: float, at: tuple[float, float]) -> np.ndarray:
    """(T, 33, 3) BlazePose person moved and scaled onto the canvas (motion kept, in shape)."""
    sl, sr = BLAZEPOSE33.index["left_shoulder"], BLAZEPOSE33.index["right_shoulder"]
    width = np.nanmedian(np.linalg.norm(kp[:, sl, :2] - kp[:, sr, :2], axis=-1))
    centre = np.nanmean(kp[..., :2].reshape(-1, 2), axis=0)
    out = kp.copy()
    out[..., :2] = (kp[..., :2] - centre) * (shoulder_px / width) + np.asarray(at)
    return out


def _speech_following(kp: np.ndarray, ts: np.ndarray, lead_s: float = LEAD_S) -> Audio:
    """16 kHz noise whose loudness is this person's wrist speed `lead_s` earlier; the audio
    starts 0.5 s before the first frame (so `Audio.start_s` matters)."""
    rate = 16000
    start = float(ts[0]) - 0.5
    t = start + np.arange(int((ts[-1] - start + 0.5) * rate)) / rate
    wrists = [BLAZEPOSE33.index["left_wrist"], BLAZEPOSE33.index["right_wrist"]]
    speed = np.linalg.norm(np.gradient(kp[:, wrists, :2], ts, axis=0), axis=-1).mean(axis=1)
    loud = np.interp(t - lead_s, ts, np.nan_to_num(speed))
    noise = np.random.default_rng(0).normal(0.0, 1.0, len(t))
    signal = 0.3 * noise * loud / loud.max()
    return Audio(signal.astype(np.float32), rate, -0.5, start)


@pytest.fixture(scope="module")
def demo_single(samples: Path) -> Pose2D:
    """mediapipe's single-person BlazePose on the real two-person Sports2D demo."""
    from gesturebank.extract.detectors.mediapipe import MediaPipeDetector

    return MediaPipeDetector().detect(iter_frames(samples / "sports2d" / "Demo" / "demo.mp4"))


@pytest.fixture(scope="module")
def duo(samples: Path, demo_single: Pose2D) -> tuple[MultiPose2D, Audio, np.ndarray]:
    """Two real single-person tracks side by side on one canvas, slots shuffled per frame.

    Slot truth after unshuffling: person A = the man on the box in the Sports2D demo (frames
    5–169, where BlazePose follows him), small and off-centre, whose wrists drive the speech;
    person B = the Pose2Sim demo subject (cam01, played forwards and backwards to last as
    long), large and central, moving on his own.
    """
    from gesturebank.extract.detectors.mediapipe import MediaPipeDetector

    a = demo_single.keypoints[5:170]
    ts = demo_single.timestamps[5:170]
    assert np.isfinite(a[..., 0]).all(axis=1).mean() > 0.95  # the man is seen throughout
    cam = samples / "pose2sim" / "Demo_SinglePerson" / "videos" / "cam01.mp4"
    b = MediaPipeDetector().detect(iter_frames(cam)).keypoints
    b = np.concatenate([b, b[-2:0:-1]] * (len(a) // (2 * len(b) - 2) + 1))[: len(a)]
    a, b = _place(a, 50, (300, 300)), _place(b, 150, (960, 540))
    both = np.stack([a, b], axis=1)
    order = np.random.default_rng(1).random(len(ts)) < 0.5  # slots carry no identity
    both[order] = both[order][:, ::-1]
    multi = MultiPose2D(both, ts, BLAZEPOSE33.name, CANVAS)
    return multi, _speech_following(a, ts), a


def _is_a(pose: Pose2D, a: np.ndarray) -> np.ndarray:
    """(T,) the pose of each frame is person A's detection (`a`: (T, 33, 3))."""
    same = (pose.keypoints == a) | (np.isnan(pose.keypoints) & np.isnan(a))
    return same.all(axis=(1, 2))


def test_speech_follower_beats_a_larger_central_person(duo) -> None:
    multi, audio, a = duo
    tracked = main_speaker(multi, TrackingConfig(speech_weight=5), audio=audio)
    (choice,) = tracked.report.choices
    assert _is_a(tracked.pose, a).all()  # the whole shot, one identity
    assert set(tracked.report.main_ids.tolist()) == {choice.main_id}
    mine, other = choice.scores[choice.main_id], choice.scores[choice.runner_up]
    assert mine["speech"] > 0.8 and other["speech"] < 0.6
    assert mine["speech"] - other["speech"] > 0.3
    assert other["size"] == 1.0 and mine["size"] < 0.5
    assert other["centrality"] > mine["centrality"]


def test_without_speech_weight_the_larger_central_person_wins(duo) -> None:
    multi, audio, a = duo
    tracked = main_speaker(multi, TrackingConfig(speech_weight=0), audio=audio)
    (choice,) = tracked.report.choices
    assert not _is_a(tracked.pose, a).any()
    assert np.isfinite(tracked.pose.keypoints[..., 0]).any(axis=1).all()  # person B throughout
    assert all(terms["speech"] == 0.0 for terms in choice.scores.values())


@pytest.mark.parametrize("kind", ["none", "silent"])
def test_no_audio_or_silence_scores_no_speech(duo, kind: str) -> None:
    multi, audio, a = duo
    quiet = None if kind == "none" else audio._replace(signal=np.zeros_like(audio.signal))
    tracked = main_speaker(multi, TrackingConfig(speech_weight=5), audio=quiet)
    (choice,) = tracked.report.choices
    assert all(terms["speech"] == 0.0 for terms in choice.scores.values())
    assert not _is_a(tracked.pose, a).any()
    assert np.isfinite(tracked.pose.keypoints[..., 0]).any(axis=1).all()  # person B throughout


def test_speech_is_matched_on_the_audio_clock(duo) -> None:
    """The same audio said to start 1.5 s later no longer matches the gesturer's motion."""
    multi, audio, a = duo
    config = TrackingConfig(speech_weight=5)
    right = main_speaker(multi, config, audio=audio)
    late = main_speaker(multi, config, audio=audio._replace(start_s=audio.start_s + 1.5))
    assert _is_a(right.pose, a).all()
    gesturer = right.report.choices[0].main_id  # ids depend on the poses only: same in both
    on_time = right.report.choices[0].scores[gesturer]["speech"]
    assert late.report.choices[0].scores[gesturer]["speech"] < 0.5 * on_time


def test_speech_score_holds_at_half_the_frame_rate_and_size(duo) -> None:
    """Every other frame, everybody half as large: the speed is in shoulder widths per second
    and the lag in seconds, so the gesturer still follows the speech and is still chosen."""
    multi, audio, a = duo
    kp = multi.keypoints[::2].copy()
    kp[..., :2] *= 0.5
    half = MultiPose2D(kp, multi.timestamps[::2], multi.skeleton, (960, 540))
    full = main_speaker(multi, TrackingConfig(speech_weight=5), audio=audio).report.choices[0]
    tracked = main_speaker(half, TrackingConfig(speech_weight=5), audio=audio)
    (choice,) = tracked.report.choices
    a_half = a[::2].copy()
    a_half[..., :2] *= 0.5
    assert _is_a(tracked.pose, a_half).all()
    speech = choice.scores[choice.main_id]["speech"]
    assert speech == pytest.approx(full.scores[full.main_id]["speech"], abs=0.1)


def test_single_person_detector_jump_is_reported_as_a_switch(demo_single: Pose2D) -> None:
    """BlazePose alone follows the man, jumps to the woman walking past (~5.7 s), then back to
    the man. Tracking reports the jump and never passes the woman's frames off as his."""
    single = demo_single
    assert np.linalg.norm(_torso(single.keypoints[180]) - WOMAN[180]) < 120
    tracked = main_speaker(MultiPose2D.from_pose2d(single))
    report = tracked.report
    assert len(report.main_switches) >= 1
    kp = tracked.pose.keypoints
    for frame, where in MAN.items():
        if np.isfinite(kp[frame, :, 0]).any():
            assert np.linalg.norm(_torso(kp[frame]) - where) < 120, frame
    for frame in (60, 120, 150):
        assert report.main_ids[frame] == report.main_id  # one identity while he is on the box
    woman = [
        t
        for t in range(len(kp))
        if np.isfinite(single.keypoints[t, :, 0]).any()
        and np.linalg.norm(_torso(single.keypoints[t]) - WOMAN[180]) < 150
    ]
    assert woman and not np.isfinite(kp[woman, :, 0]).any()


def test_blazepose_on_the_two_person_demo_keeps_the_man(samples: Path) -> None:
    """The multi-person detector on the real Sports2D demo with real (unrelated) speech."""
    pytest.importorskip("gesturebank.extract.detectors.blazepose")
    video = samples / "talking" / "outdoor" / "sports2d_arctic.mp4"
    detector = DETECTORS.create("blazepose", BlazePoseConfig(max_people=2))
    multi = detector.detect_people(iter_frames(video))
    tracked = main_speaker(multi, audio=read_audio(video, sample_rate=16000))
    report = tracked.report
    kp = tracked.pose.keypoints
    first = report.main_ids[60]
    for frame in (60, 120, 150):
        assert report.main_ids[frame] == first  # one identity while he is on the box
        assert np.linalg.norm(_torso(kp[frame]) - MAN[frame]) < 120, frame
    for frame, where in WOMAN.items():
        if np.isfinite(kp[frame, :, 0]).any():
            assert np.linalg.norm(_torso(kp[frame]) - where) > 300, frame
    choice = next(c for c in report.choices if c.main_id == first)
    assert choice.runner_up is not None  # the woman was seen and scored
