"""Where a take is cut into clips: shots, speaker changes, absences, audio, min/max length."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gesturebank.config import ClipsConfig
from gesturebank.datasets.cut import cut_clips


def cut(n: int, fps: float = 30.0, **kw):
    t = np.arange(n) / fps
    args = {
        "timestamps": t,
        "cuts": np.zeros(0),
        "speaker": np.zeros(n, int),
        "present": np.ones(n, bool),
        "usable": np.ones(n, bool),
        "audio_span": (0.0, t[-1]),
        "config": ClipsConfig(),
    }
    args.update(kw)
    return t, cut_clips(**args)


def spans(result) -> list[tuple[int, int, str]]:
    return [(s.start, s.stop, s.reason) for s in (*result.clips, *result.dropped)]


def test_an_uncut_take_is_one_clip() -> None:
    _, r = cut(300)
    assert [(c.start, c.stop) for c in r.clips] == [(0, 300)] and not r.dropped
    assert r.clips[0].duration_s == pytest.approx(10.0)


def test_a_clip_never_spans_a_shot_cut_or_a_speaker_change() -> None:
    _t, r = cut(600, cuts=np.array([100 / 30]))
    assert [(c.start, c.stop) for c in r.clips] == [(0, 100), (100, 600)]
    speaker = np.zeros(600, int)
    speaker[400:] = 7
    _, r = cut(600, speaker=speaker)
    assert [(c.start, c.stop) for c in r.clips] == [(0, 400), (400, 600)]


def test_short_absences_stay_inside_long_ones_cut() -> None:
    present = np.ones(900, bool)
    present[200:210] = False  # 0.33 s ≤ max_gap_s 0.5: masked inside the clip
    present[500:530] = False  # 1 s: the clip ends
    _, r = cut(900, present=present)
    assert [(c.start, c.stop) for c in r.clips] == [(0, 500), (530, 900)]
    assert [(d.start, d.stop, d.reason) for d in r.dropped] == [(500, 530, "main speaker absent")]


def test_unusable_but_present_has_its_own_reason() -> None:
    usable = np.ones(600, bool)
    usable[:60] = False
    _, r = cut(600, usable=usable)
    assert r.dropped[0].start == 0 and r.dropped[0].stop == 60
    assert r.dropped[0].reason.startswith("no usable pose")


def test_too_short_pieces_are_dropped_with_their_length() -> None:
    _, r = cut(600, cuts=np.array([2.0]))  # a 2 s shot, then an 18 s one
    assert [(c.start, c.stop) for c in r.clips] == [(60, 600)]
    assert r.dropped[0].reason == "too short: 2.00 s < 3 s"


def test_no_audio_is_silence_cut_when_long_marked_when_short() -> None:
    """Issue 32: missing audio counts as silence (the VAD hears none there, so its silences
    cover it): 8 s without audio cut, named "no audio"; 0.5 s late audio stays in the clip."""
    _t, r = cut(600, audio_span=(0.0, 12.0), silences=[(12.0, 20.0)])
    assert r.clips[-1].end_s <= 12.0 + 1 / 30
    assert r.dropped[-1].reason == "no audio" and r.dropped[-1].stop == 600
    _t, late = cut(600, audio_span=(0.5, 20.0))  # 0.5 s: shorter than any cutting silence
    assert [(c.start, c.stop) for c in late.clips] == [(0, 600)] and not late.dropped


def test_max_s_splits_into_equal_parts() -> None:
    _, r = cut(3000, config=ClipsConfig(max_s=30.0))  # 100 s → 4 parts of 25 s
    assert len(r.clips) == 4
    assert [c.duration_s for c in r.clips] == pytest.approx([25.0] * 4, abs=0.05)
    assert r.clips[0].stop == r.clips[1].start


def test_frame_rate_does_not_change_the_cut() -> None:
    """The same take at 30 and 60 fps: the same clips in seconds."""
    results = []
    for fps in (30.0, 60.0):
        n = int(20 * fps)
        t = np.arange(n) / fps
        present = ~((t >= 7.0) & (t < 8.0))
        _, r = cut(n, fps, present=present, cuts=np.array([15.0]))
        results.append([(round(c.start_s, 1), round(c.end_s, 1)) for c in r.clips])
    assert results[0] == results[1] == [(0.0, 7.0), (8.0, 15.0), (15.0, 20.0)]


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.booleans(), min_size=30, max_size=400),
    st.lists(st.integers(0, 399), max_size=4),
    st.integers(0, 3),
)
def test_clips_and_spans_cover_every_frame_once(present, cut_frames, speakers) -> None:
    n = len(present)
    rng = np.random.default_rng(len(present) + speakers)
    speaker = np.repeat(rng.integers(0, speakers + 1, 4), -(-n // 4))[:n]
    _t, r = cut(n, present=np.array(present), cuts=np.array(cut_frames) / 30.0, speaker=speaker)
    covered = np.zeros(n, int)
    for s in (*r.clips, *r.dropped):
        covered[s.start : s.stop] += 1
    assert (covered == 1).all()
    for c in r.clips:
        assert c.duration_s >= 3.0 - 1e-9
        assert present[c.start] and present[c.stop - 1]  # clips start and end on a seen speaker
        assert len(set(speaker[c.start : c.stop])) == 1
        inside = [f for f in cut_frames if c.start < f < c.stop]
        assert not inside


def test_a_long_silence_cuts_the_clip_with_its_reason() -> None:
    """Issue 32: the silences given (those over speech.max_silence_s) give no clip; the speech
    either side gives one clip each."""
    from gesturebank.datasets.cut import SILENCE

    _, r = cut(900, silences=[(10.0, 13.0)])  # 30 s take, 3 s silent from frame 300 to 390
    assert [(c.start, c.stop) for c in r.clips] == [(0, 300), (390, 900)]
    assert [(d.start, d.stop, d.reason) for d in r.dropped] == [(300, 390, SILENCE)]
    assert SILENCE.startswith("no speech") and "silence" in SILENCE
    _, whole = cut(900, silences=[(0.0, 31.0)])
    assert not whole.clips and [d.reason for d in whole.dropped] == [SILENCE]


def test_missing_audio_is_padded_with_silence() -> None:
    """The build's features cover every frame: a track 0.5 s late (and short at the end) is
    padded with digital silence, its samples kept where they were."""
    from gesturebank.app.clip import covering
    from gesturebank.audio.io import Audio

    t = np.arange(0, 3.0, 1 / 30)
    late = Audio(np.ones(16000, np.float32), 16000, 0.5, 0.5)  # 0.5–1.5 s
    heard = covering(late, t, margin_s=0.025)
    assert heard.start_s <= -0.025 and heard.start_s + len(heard.signal) / 16000 >= 3.0 + 0.025
    first = round((0.5 - heard.start_s) * 16000)
    assert not heard.signal[:first].any() and heard.signal[first : first + 16000].all()
    assert not heard.signal[first + 16000 :].any()
    whole = Audio(np.ones(16000 * 4, np.float32), 16000, 0.0, -0.5)
    assert covering(whole, t, margin_s=0.025) is whole  # nothing missing: unchanged
