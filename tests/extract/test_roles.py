"""Who speaks when: the role track from mouth openings against the speech (the turn-taking
conversation's speech, with mouths that follow each speaker's own speech 80-200 ms late with
noise, as a face landmark model would measure them), the main speaker switching with the turns
by person id, and the choice where no mouth follows the speech (dubbed footage)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturebank.audio.io import Audio
from gesturebank.clip import ROLES
from gesturebank.config import SpeechConfig, TrackingConfig
from gesturebank.extract import roles as R
from gesturebank.extract.speech import speech_envelope
from gesturebank.extract.tracking import main_speaker, track_ids, turns
from gesturebank.footage import SPEECH_RATE
from gesturebank.testing import conversation
from tests.extract.test_tracking import person, scene

CONFIG = SpeechConfig()
GUARD_S = 0.5  # frames this close to a turn's start or end are not judged (issue 32)


def test_role_codes_are_the_clip_roles() -> None:
    assert (ROLES[R.UNKNOWN], ROLES[R.SPEAKING], ROLES[R.LISTENING]) == (
        "unknown",
        "speaking",
        "listening",
    )


def test_turns_hold_the_speaker_through_pauses_and_ignore_short_blips() -> None:
    ts = np.arange(100) / 10.0  # 10 s at 10 Hz
    speaking = np.zeros((100, 2), bool)
    speaking[5:30, 0] = True  # A speaks from 0.5 s, pauses 30-35
    speaking[35:45, 0] = True
    speaking[50:52, 1] = True  # B: a 0.2 s blip
    speaking[60:90, 1] = True  # B's turn from 6 s
    label = turns(speaking=speaking, rank=np.array([0.0, 1.0]), timestamps=ts, min_turn_s=1.0)
    assert (label[:60] == 0).all()  # from the first frame, through the pause and the blip
    assert (label[60:] == 1).all()  # to the end: held after B stops
    nobody = turns(speaking=speaking[:, :0], rank=np.zeros(0), timestamps=ts, min_turn_s=1.0)
    assert (nobody == -1).all()


@pytest.fixture(scope="module")
def talk(samples: Path) -> tuple[np.ndarray, np.ndarray, Audio, np.ndarray]:
    """Frame times (15 Hz), the speaker per frame (-1 between turns), the audio, and measured
    mouth openings (S, 2): closed 0.01, open up to 0.13 of the face's height (the face
    landmark model's scale), with 0.003 of landmark jitter."""
    signal, spoken = conversation.speech_track(samples)
    times = conversation.video_times(signal)
    mouth = conversation.mouths(signal, spoken, times=times, seed=1)
    rng = np.random.default_rng(2)
    opening = 0.01 + 0.12 * mouth.T + rng.normal(0, 0.003, (len(times), 2))
    audio = Audio(signal.astype(np.float32), SPEECH_RATE, 0.0, 0.0)
    who = np.full(len(times), -1)
    guard = np.zeros(len(times), bool)
    for a, b, w in spoken:
        who[(times >= a) & (times < b)] = w
        guard |= (np.abs(times - a) < GUARD_S) | (np.abs(times - b) < GUARD_S)
    judged = ~guard & (who >= 0)
    return times, np.where(judged, who, -2), audio, opening


def _roles(times: np.ndarray, audio: Audio, opening: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    env = speech_envelope(audio=audio, timestamps=times, smooth_s=R.ENVELOPE_SMOOTH_S)
    heard = R.heard_before(audio, times=times, config=CONFIG)
    rate = 1.0 / float(np.median(np.diff(times)))
    return R.sampled_roles(
        opening=opening, envelope=np.nan_to_num(env), heard=heard, rate_hz=rate, config=CONFIG
    )


def test_the_role_track_follows_the_turns(talk) -> None:  # type: ignore[no-untyped-def]
    times, who, audio, opening = talk
    _, role = _roles(times, audio, opening)
    judged = who >= 0
    for fig in (0, 1):
        want = np.where(who[judged] == fig, R.SPEAKING, R.LISTENING)
        match = float(np.mean(role[judged, fig] == want))
        print(f"\nfigure {fig}: role matches the turns on {match:.1%} of judged frames")
        assert match >= 0.9
    # the listener's mouth moves now and then: it never counts as speaking for long
    assert np.mean(role[judged][who[judged] == 0, 1] == R.SPEAKING) < 0.1


def test_the_main_speaker_switches_with_the_turns_by_person_id(talk) -> None:  # type: ignore[no-untyped-def]
    times, who, audio, opening = talk
    n = len(times)
    # Two still people side by side; figure 0 on the left.
    multi = scene([[person(300, 500), person(700, 500)] for _ in range(n)], shuffle=3)
    multi = type(multi)(multi.keypoints, times, multi.skeleton, multi.image_size, multi.ids)
    ids = track_ids(multi, TrackingConfig(), cuts=None)
    left = np.array([ids[t, np.argmin(multi.keypoints[t, :, 11, 0])] for t in range(n)])
    assert len(np.unique(left)) == 1
    person_of = {0: int(left[0]), 1: int(1 - left[0])}
    score, role = _roles(times, audio, opening)
    # roles per track id (column = track id here: the ids are 0 and 1)
    cols = [person_of[0], person_of[1]]
    by_id = np.zeros((n, 2), np.int8)
    by_id[:, cols] = role
    sc = np.zeros((n, 2), np.float32)
    sc[:, cols] = score
    roles = R.Roles(np.array([0, 1]), sc, by_id, np.ones((n, 2), bool), np.ones((n, 2), bool))
    tracked = main_speaker(multi, TrackingConfig(), ids=ids, roles=roles, speech=CONFIG)
    main = tracked.report.main_ids
    judged = who >= 0
    want = np.array([person_of[w] for w in who[judged]])
    assert np.mean(main[judged] == want) >= 0.9
    order = [c.main_id for c in tracked.report.choices]
    assert order == [person_of[0], person_of[1], person_of[0]]  # one choice per turn
    assert all(c.reason == "speaks" for c in tracked.report.choices)


def _still_people(n: int, xs: list[float]):  # type: ignore[no-untyped-def]
    multi = scene([[person(x, 500) for x in xs] for _ in range(n)])
    ids = track_ids(multi, TrackingConfig(), cuts=None)
    return multi, ids


def test_dubbed_speech_over_several_people_facing_the_camera_makes_nobody_the_speaker() -> None:
    n = 90
    multi, ids = _still_people(n, [300, 700])
    k = np.unique(ids[ids >= 0])
    listening = np.full((n, 2), R.LISTENING, np.int8)  # mouths seen, following nothing
    roles = R.Roles(
        k, np.zeros((n, 2), np.float32), listening, np.ones((n, 2), bool), np.ones((n, 2), bool)
    )
    tracked = main_speaker(multi, TrackingConfig(), ids=ids, roles=roles, speech=CONFIG)
    assert (tracked.report.main_ids == -1).all()
    assert [c.reason for c in tracked.report.choices] == ["nobody"]
    assert tracked.roles is not None and (tracked.roles.role == R.UNKNOWN).all()
    # One of them facing away: the one facing the camera is kept, role unknown.
    facing = np.ones((n, 2), bool)
    facing[:, 1] = False
    roles = R.Roles(k, roles.score, listening, facing, facing)
    tracked = main_speaker(multi, TrackingConfig(), ids=ids, roles=roles, speech=CONFIG)
    assert (tracked.report.main_ids == k[0]).all()
    assert (tracked.role_of(tracked.report.main_ids) == R.UNKNOWN).all()
    # Alone: kept as before.
    multi, ids = _still_people(n, [500])
    roles = R.Roles(
        np.array([0]), np.zeros((n, 1), np.float32), listening[:, :1], facing[:, 1:], facing[:, 1:]
    )
    tracked = main_speaker(multi, TrackingConfig(), ids=ids, roles=roles, speech=CONFIG)
    assert (tracked.report.main_ids == 0).all()


def test_spread_takes_the_nearest_sample() -> None:
    rows = np.array([0, 4, 8])
    out = R.spread(rows, np.array([10, 20, 30]), n_frames=10, fill=-1)
    np.testing.assert_array_equal(out, [10, 10, 10, 20, 20, 20, 20, 30, 30, 30])
    np.testing.assert_array_equal(
        R.spread(rows[:0], np.zeros(0), n_frames=3, fill=-1), [-1, -1, -1]
    )
