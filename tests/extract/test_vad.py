"""Speech activity (Silero VAD): the chunk framing by hand, the hysteresis and the silence rule on
hand-built masks, and on real speech (CMU ARCTIC) speech where the signal has energy and silence
on inserted digital silence, a silent track and time without audio."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturebank.audio import vad
from gesturebank.audio.io import Audio, read_audio
from gesturebank.config import SpeechConfig

RATE = 16000


def test_chunks_are_prefixed_with_the_previous_chunks_last_64_samples() -> None:
    x = np.arange(1, 601, dtype=np.float32)  # 600 samples: one full chunk and 88 over
    rows = vad.model_inputs(x)
    assert rows.shape == (2, 576)
    np.testing.assert_array_equal(rows[0, :64], 0)  # no chunk before the first
    np.testing.assert_array_equal(rows[0, 64:], np.arange(1, 513))
    np.testing.assert_array_equal(rows[1, :64], np.arange(449, 513))  # samples 448..511
    np.testing.assert_array_equal(rows[1, 64:152], np.arange(513, 601))
    np.testing.assert_array_equal(rows[1, 152:], 0)  # end padding


def test_hysteresis_starts_at_threshold_and_stops_below_release() -> None:
    p = np.array([0.1, 0.45, 0.5, 0.4, 0.36, 0.34, 0.45, 0.6, 0.2])
    on = vad.hysteresis(p, threshold=0.5, release_threshold=0.35)
    np.testing.assert_array_equal(on, [0, 0, 1, 1, 1, 0, 0, 1, 0])


def test_release_above_threshold_is_refused() -> None:
    with pytest.raises(ValueError, match="release_threshold"):
        SpeechConfig(threshold=0.4, release_threshold=0.5)


def test_silences_over_max_are_cut_and_shorter_ones_marked() -> None:
    speech = np.ones(1000, bool)  # 10 s at 100 Hz from t0 = 2 s
    speech[:50] = False  # 0.5 s leading silence (a late track): marked
    speech[300:550] = False  # 2.5 s: cut
    speech[700:900] = False  # exactly 2.0 s: not over the limit, marked
    act = vad.SpeechActivity(2.0, 100.0, speech.astype(np.float32), speech)
    s = vad.silences(act, max_silence_s=2.0)
    np.testing.assert_allclose(s.cut, [(5.0, 7.5)])
    np.testing.assert_allclose(s.marked, [(2.0, 2.5), (9.0, 11.0)])


def _speech(samples: Path, name: str) -> np.ndarray:
    audio = read_audio(samples / "speech" / f"{name}.wav", sample_rate=RATE)
    assert audio is not None
    return audio.signal


def _activity(signal: np.ndarray, start_s: float = 0.0, n_frames: int | None = None):  # type: ignore[no-untyped-def]
    n = n_frames if n_frames is not None else int(len(signal) / RATE * 100)
    return vad.speech_activity(
        Audio(signal, RATE, start_s, start_s), t0=0.0, n_frames=n, config=SpeechConfig()
    )


def test_speech_is_found_where_the_signal_has_energy(samples: Path) -> None:
    x = _speech(samples, "arctic_a0007")
    act = _activity(x)
    frames = x[: len(act.speech) * 160].reshape(-1, 160)
    db = 20 * np.log10(np.sqrt(np.mean(frames**2, axis=1)) + 1e-9)
    loud = db > db.max() - 30  # within 30 dB of the loudest 10 ms
    assert act.speech[loud].mean() >= 0.95
    assert np.median(act.probability[loud]) > 0.9
    # The recording's own pauses before and after the sentence (room noise, -30 to -43 dB).
    before, after = act.times < 0.4, act.times > act.times[-1] - 0.25
    assert (db[before | after] < db.max() - 25).all()
    assert not act.speech[before].any() and not act.speech[after].any()


def test_inserted_silence_is_silence_and_a_30_percent_gap_is_cut(samples: Path) -> None:
    a, b = _speech(samples, "arctic_a0007"), _speech(samples, "arctic_a0009")
    gap = np.zeros(int(0.3 / 0.7 * (len(a) + len(b))), np.float32)  # 30 % of the whole
    x = np.concatenate([a, gap, b])
    act = _activity(x)
    g0, g1 = len(a) / RATE, (len(a) + len(gap)) / RATE
    inside = (act.times >= g0 + 0.1) & (act.times < g1 - 0.1)
    assert (~act.speech[inside]).mean() >= 0.95
    assert np.max(act.probability[inside]) < 0.2
    cut = vad.silences(act, max_silence_s=SpeechConfig().max_silence_s).cut
    assert any(s <= g0 + 0.5 and e >= g1 - 0.5 for s, e in cut), cut


def test_silent_or_missing_audio_is_silence(samples: Path) -> None:
    silent = _activity(np.zeros(5 * RATE, np.float32))
    assert (~silent.speech).mean() >= 0.95
    none = vad.speech_activity(None, t0=0.0, n_frames=300, config=SpeechConfig())
    assert not none.speech.any() and not none.probability.any()
    # A track starting 0.5 s late and ending early: the time it does not cover is silence.
    x = _speech(samples, "arctic_a0007")
    late = _activity(x, start_s=0.5, n_frames=int(len(x) / RATE * 100) + 100)
    assert not late.speech[:50].any() and not late.speech[-50:].any()
    assert late.speech.mean() > 0.5


def test_other_sample_rates_are_resampled_to_16k(samples: Path) -> None:
    x = _speech(samples, "arctic_a0007")
    at_44k = read_audio(samples / "speech" / "arctic_a0007.wav", sample_rate=44100)
    assert at_44k is not None
    n = int(len(x) / RATE * 100)
    ref = vad.speech_activity(Audio(x, RATE, 0.0), t0=0.0, n_frames=n, config=SpeechConfig())
    other = vad.speech_activity(at_44k, t0=0.0, n_frames=n, config=SpeechConfig())
    assert np.mean(ref.speech == other.speech) > 0.97


@pytest.mark.filterwarnings("ignore:path is deprecated:DeprecationWarning")  # silero-vad's own
def test_chunk_probabilities_match_the_wheels_own_onnx_wrapper(samples: Path) -> None:
    """The reference: silero-vad's own ONNX wrapper (it needs torch, which `train` installs)."""
    torch = pytest.importorskip("torch")
    silero = pytest.importorskip("silero_vad")
    x = _speech(samples, "arctic_a0009")
    reference = silero.load_silero_vad(onnx=True).audio_forward(torch.from_numpy(x), RATE)
    ours = vad.chunk_probabilities(x)
    np.testing.assert_allclose(ours, reference.numpy().ravel(), atol=1e-5)


def test_a_take_asking_twice_runs_the_model_once(monkeypatch) -> None:
    """Who speaks and the clips' silences both ask for a take's activity (issue 43): the same
    samples reuse the model's run, other samples (or one sample changed) run it again."""
    runs: list[int] = []
    real = vad.chunk_probabilities

    def counted(signal: np.ndarray) -> np.ndarray:
        runs.append(len(signal))
        return real(signal)

    monkeypatch.setattr(vad, "chunk_probabilities", counted)
    signal = np.random.default_rng(3).uniform(-0.1, 0.1, RATE).astype(np.float32)
    audio = Audio(signal, RATE, 0.0, 0.0)
    first, again = (
        vad.speech_activity(audio, t0=0.0, n_frames=n, config=SpeechConfig()) for n in (100, 90)
    )
    assert len(runs) == 1
    np.testing.assert_array_equal(first.probability[:90], again.probability)
    changed = signal.copy()
    changed[100] += 0.01
    vad.speech_activity(Audio(changed, RATE, 0.0, 0.0), t0=0.0, n_frames=100, config=SpeechConfig())
    assert len(runs) == 2
