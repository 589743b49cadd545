"""Mouth activity: the face crop from pose keypoints (by hand and as geometry properties), the
opening ratio by hand, the speaking score on hand-built signals, and on real footage the face
landmark model on the faces BlazePose gives (Pose2Sim Demo_MultiPerson cam04, the talking demos),
people who do not speak."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gesturebank.audio.io import read_audio
from gesturebank.config import BlazePoseConfig, SpeechConfig, VideoConfig
from gesturebank.extract import mouth
from gesturebank.extract.detectors import DETECTORS
from gesturebank.extract.speech import speech_envelope
from gesturebank.extract.video import iter_frames
from gesturebank.skeletons import COCO17

CONFIG = SpeechConfig()


def _face(
    nose: tuple[float, float],
    left_eye: tuple[float, float],
    right_eye: tuple[float, float],
    confidence: float = 0.9,
) -> np.ndarray:
    kp = np.full((len(COCO17), 3), np.nan, np.float32)
    for name, xy in (("nose", nose), ("left_eye", left_eye), ("right_eye", right_eye)):
        kp[COCO17.index[name]] = (*xy, confidence)
    return kp


def _box(kp: np.ndarray) -> tuple[mouth.Roi | None, str]:
    return mouth.face_box(keypoints=kp, skeleton=COCO17.name, config=CONFIG)


def test_frontal_face_gets_a_level_crop_on_the_nose() -> None:
    roi, why = _box(_face((100, 110), (115, 95), (85, 95)))  # eyes 30 px apart
    assert roi is not None and why == ""
    assert (roi.cx, roi.cy, roi.angle) == (100, 110, 0)
    assert roi.side == pytest.approx(mouth.CROP_PER_WIDTH * mouth.WIDTH_PER_EYES * 30)


def test_faces_turned_away_small_or_unseen_get_no_crop() -> None:
    assert _box(_face((100, 110), (85, 95), (115, 95)))[1] == "facing away"  # seen from behind
    assert _box(_face((118, 110), (115, 95), (85, 95)))[1] == "facing away"  # turn 1.2
    assert _box(_face((100, 110), (105, 95), (95, 95)))[1] == "face too small"  # 23 px wide
    assert _box(_face((100, 110), (115, 95), (85, 95), confidence=0.2))[1] == "face unseen"
    assert _box(_face((110, 110), (115, 95), (85, 95)))[1] == ""  # turn 0.67: still facing


@given(
    angle=st.floats(-1.2, 1.2),
    scale=st.floats(1.0, 4.0),  # the base face is 69 px wide: 48 px is the smallest
    shift=st.tuples(st.floats(-500, 500), st.floats(-500, 500)),
)
def test_crop_follows_the_face_under_rotation_scale_and_shift(
    angle: float, scale: float, shift: tuple[float, float]
) -> None:
    c, s = np.cos(angle), np.sin(angle)

    def move(p: tuple[float, float]) -> tuple[float, float]:
        x, y = scale * p[0], scale * p[1]
        return (c * x - s * y + shift[0], s * x + c * y + shift[1])

    base = ((0.0, 15.0), (15.0, 0.0), (-15.0, 0.0))  # nose, left eye, right eye
    ref, _ = _box(_face(*base))
    roi, _ = _box(_face(*(move(p) for p in base)))
    assert ref is not None and roi is not None
    assert roi.side == pytest.approx(scale * ref.side, rel=1e-4)
    assert (roi.cx, roi.cy) == pytest.approx(move((0.0, 15.0)), abs=1e-3)
    assert roi.angle == pytest.approx(angle, abs=1e-5)


def test_opening_is_lip_gap_over_forehead_to_chin() -> None:
    pts = np.zeros((468, 2))
    pts[mouth.FOREHEAD], pts[mouth.CHIN] = (50, 10), (50, 130)  # face 120 px high
    pts[mouth.UPPER_LIP], pts[mouth.LOWER_LIP] = (50, 100), (53, 104)  # lips 5 px apart
    assert mouth.mouth_opening(pts) == pytest.approx(5 / 120)
    assert np.isnan(mouth.mouth_opening(np.zeros((468, 2))))


# ---------------------------------------------------------------- speaking score


def _envelope(samples: Path, fps: float) -> np.ndarray:
    audio = read_audio(samples / "speech" / "arctic_a0009.wav", sample_rate=16000)
    assert audio is not None
    ts = np.arange(int(len(audio.signal) / 16000 * fps)) / fps
    return speech_envelope(audio=audio, timestamps=ts, smooth_s=0.1)


def test_a_mouth_following_the_speech_late_scores_high_and_a_random_one_low(
    samples: Path,
) -> None:
    fps = 30.0
    env = _envelope(samples, fps)
    rng = np.random.default_rng(3)
    delay = 4  # 133 ms behind the speech
    follower = 0.15 * np.r_[np.zeros(delay), env[:-delay]] / env.max()
    follower += rng.normal(0, 0.01, len(env))
    chatter = np.convolve(rng.normal(0, 0.05, len(env)), np.ones(5) / 5, "same")
    speaker = mouth.speaking_score(opening=follower, envelope=env, rate_hz=fps, config=CONFIG)
    other = mouth.speaking_score(opening=chatter, envelope=env, rate_hz=fps, config=CONFIG)
    assert np.nanmedian(speaker) > 0.8
    assert np.nanmedian(other) < 0.5
    assert np.mean(speaker > other) > 0.9


def test_a_still_mouth_scores_zero_and_no_speech_or_no_mouth_has_no_score(samples: Path) -> None:
    fps = 30.0
    env = _envelope(samples, fps)
    rng = np.random.default_rng(0)
    # Following the speech perfectly but within the landmark jitter of a closed mouth: still.
    tiny = 0.01 * env / env.max() + 0.005
    score = mouth.speaking_score(opening=tiny, envelope=env, rate_hz=fps, config=CONFIG)
    np.testing.assert_array_equal(score, 0.0)
    moving = rng.normal(0, 0.05, len(env))
    for opening, envelope in ((moving, np.zeros(len(env))), (np.full(len(env), np.nan), env)):
        score = mouth.speaking_score(opening=opening, envelope=envelope, rate_hz=fps, config=CONFIG)
        assert np.isnan(score).all()


# ---------------------------------------------------------------- real footage


@pytest.fixture(scope="module")
def cam04(samples: Path) -> tuple[list[tuple[float, np.ndarray]], np.ndarray, str]:
    """2 s of Demo_MultiPerson cam04 (the woman faces the camera and does not speak): frames,
    the BlazePose keypoints of the person whose face is seen most, skeleton name."""
    path = samples / "pose2sim" / "Demo_MultiPerson" / "videos" / "cam04.mp4"
    frames = list(iter_frames(path, VideoConfig(end_s=2.0)))
    multi = DETECTORS.create("blazepose", BlazePoseConfig(), threads=1).detect_people(iter(frames))
    boxes = [
        sum(_box_of(multi.keypoints[i, p], multi.skeleton) is not None for i in range(len(frames)))
        for p in range(multi.keypoints.shape[1])
    ]
    return frames, multi.keypoints[:, int(np.argmax(boxes))], multi.skeleton


def _box_of(kp: np.ndarray, skeleton: str) -> mouth.Roi | None:
    return mouth.face_box(keypoints=kp, skeleton=skeleton, config=CONFIG)[0]


def test_closed_mouths_measure_small_and_a_drawn_open_mouth_larger(cam04) -> None:  # type: ignore[no-untyped-def]
    frames, kp, skeleton = cam04
    openings = mouth.mouth_openings(
        (f for _, f in frames), keypoints=kp, skeleton=skeleton, config=CONFIG
    )
    assert np.isfinite(openings).mean() > 0.7
    assert np.nanmax(openings) < 0.05  # lips closed: a few % of the face's height
    # Paint a dark open mouth between the lips of one frame: the model opens its lips.
    i = int(np.flatnonzero(np.isfinite(openings))[-1])
    image, roi = frames[i][1].copy(), _box_of(kp[i], skeleton)
    assert roi is not None
    model = mouth.FaceLandmarker()
    p = model(image, roi).points
    centre = (p[mouth.UPPER_LIP] + p[mouth.LOWER_LIP]) / 2
    width = float(np.hypot(*(p[78] - p[308])))  # inner mouth corners
    height = 0.1 * float(np.hypot(*(p[mouth.FOREHEAD] - p[mouth.CHIN])))
    axes = (round(width / 2), round(height / 2))
    cv2.ellipse(
        image,
        tuple(np.round(centre).astype(int)),
        axes,
        np.degrees(roi.angle),
        0,
        360,
        (40, 10, 10),
        -1,
    )
    drawn = model(image, roi)
    assert drawn.presence > 0.5
    assert drawn.opening > 3 * openings[i]


def test_people_who_do_not_speak_are_not_speakers(samples: Path, cam04) -> None:  # type: ignore[no-untyped-def]
    # cam04's woman against speech she does not say.
    frames, kp, skeleton = cam04
    fps = 1 / float(np.median(np.diff([t for t, _ in frames])))
    openings = mouth.mouth_openings(
        (f for _, f in frames), keypoints=kp, skeleton=skeleton, config=CONFIG
    )
    env = _envelope(samples, fps)[: len(openings)]
    score = mouth.speaking_score(opening=openings, envelope=env, rate_hz=fps, config=CONFIG)
    assert np.isfinite(score).mean() > 0.7 and np.nanmedian(score) == 0.0  # a still mouth
    assert np.mean(score > 0.5) < 0.1
    # The talking lab demo (speech dubbed over a Pose2Sim scene) against its own audio: the
    # person is seen in profile or from behind; crops are made on 55 of 120 frames but the
    # model finds no face in them (presence < 0.5), so no mouth is measured and nobody scores.
    path = samples / "talking" / "lab" / "cam01_arctic.mp4"
    lab = list(iter_frames(path, VideoConfig(end_s=2.0)))
    times = np.array([t for t, _ in lab])
    audio = read_audio(path, sample_rate=16000)
    assert audio is not None
    env = speech_envelope(audio=audio, timestamps=times, smooth_s=0.1)
    rate = 1 / float(np.median(np.diff(times)))
    multi = DETECTORS.create("blazepose", BlazePoseConfig(), threads=1).detect_people(iter(lab))
    for person in range(multi.keypoints.shape[1]):
        openings = mouth.mouth_openings(
            (f for _, f in lab),
            keypoints=multi.keypoints[:, person],
            skeleton=multi.skeleton,
            config=CONFIG,
        )
        score = mouth.speaking_score(opening=openings, envelope=env, rate_hz=rate, config=CONFIG)
        assert np.mean(score > 0.5) < 0.2  # NaN (unmeasured) is not speaking
