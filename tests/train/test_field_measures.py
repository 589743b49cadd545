"""The field's measures: GENEA 2022's acceleration/jerk, histograms and FGD; BEAT's beat
consistency; the natural and shuffled-clip baselines."""

from __future__ import annotations

import json
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest

import gesturebank.datasets as gds
from gesturebank.audio.features import features
from gesturebank.audio.io import read_audio
from gesturebank.config import AudioConfig, EvalConfig
from gesturebank.datasets.torch import Segment, load_segments, make_segment, split_items
from gesturebank.train.eval import beats as B
from gesturebank.train.eval import fgd as F
from gesturebank.train.eval import metrics as M
from gesturebank.train.eval.evaluate import shuffled_clip
from gesturebank.train.eval.field import known_runs

RATE = 100.0


@pytest.fixture()
def rng() -> np.random.Generator:
    return np.random.default_rng(0)


# --------------------------------------------------------------------------------------------------
# GENEA's acceleration and jerk


def test_derivatives_of_a_cubic_and_of_constant_velocity() -> None:
    t = np.arange(50) / RATE
    cubic = np.stack([t**3, -2 * t**3], axis=1)  # x''' = 6 and −12
    jerk = M.derivative_norms(cubic, rate_hz=RATE, order=3)
    np.testing.assert_allclose(jerk, np.broadcast_to([6.0, 12.0], jerk.shape), rtol=1e-6)
    assert M.average_derivative(cubic, rate_hz=RATE, order=3) == pytest.approx(9.0, rel=1e-6)
    line = np.stack([0.5 * t, t], axis=1)
    assert M.average_derivative(line, rate_hz=RATE, order=2) == pytest.approx(0.0, abs=1e-9)
    assert M.average_derivative(line, rate_hz=RATE, order=1) == pytest.approx(0.75)


def test_position_derivatives_take_the_norm_over_xyz() -> None:
    steps = np.zeros((3, 1, 3))
    steps[1, 0] = [3.0, 4.0, 0.0]  # a 5-unit step, then back
    np.testing.assert_allclose(M.derivative_norms(steps, rate_hz=2.0, order=1), [[10.0], [10.0]])
    with pytest.raises(ValueError, match="order 3 needs more than 3 frames"):
        M.derivative_norms(steps, rate_hz=2.0, order=3)


# --------------------------------------------------------------------------------------------------
# Beat consistency


def test_beat_consistency_by_hand() -> None:
    # audio beats at 1.0 and 2.0 s, one motion beat at 1.3 s: d = 0.3 and 0.7 s
    got = B.beat_consistency(audio_beats_s=[1.0, 2.0], motion_beats_s=[1.3], sigma_s=0.3)
    want = (np.exp(-0.09 / 0.18) + np.exp(-0.49 / 0.18)) / 2
    assert got == pytest.approx(want, rel=1e-12)
    assert B.beat_consistency(audio_beats_s=[1.0], motion_beats_s=[1.0], sigma_s=0.3) == 1.0
    assert B.beat_consistency(audio_beats_s=[1.0], motion_beats_s=[], sigma_s=0.3) == 0.0
    assert B.beat_consistency(audio_beats_s=[], motion_beats_s=[1.0], sigma_s=0.3) is None


def test_onset_strength_is_the_mean_rise_over_bands() -> None:
    bands = np.array([[0.0, 1.0], [2.0, 0.0], [3.0, 4.0]])
    np.testing.assert_allclose(B.onset_strength(bands), [0.0, 1.0, 2.5])  # (2+0)/2, (1+4)/2


def test_motion_beats_are_speed_minima() -> None:
    t = np.arange(300) / RATE
    angles = np.zeros((300, 11))
    angles[:, 3] = np.sin(2 * np.pi * t)  # speed 0 at the turns, t = 0.25 + k/2
    beats = B.motion_beats(angles, rate_hz=RATE, order_s=0.1) / RATE
    np.testing.assert_allclose(beats, [0.25, 0.75, 1.25, 1.75, 2.25, 2.75], atol=0.011)
    assert B.motion_beats(np.zeros((300, 11)), rate_hz=RATE, order_s=0.1).size == 0


@pytest.fixture(scope="module")
def speech_onsets(samples: Path) -> np.ndarray:
    """Onset frames of the real speech of a sample clip (LogFB-26, the dataset's features)."""
    audio = AudioConfig()
    clip = sorted((samples / "talking").glob("*/*.mp4"))[0]
    track = read_audio(clip, sample_rate=audio.sample_rate)
    assert track is not None
    feats = features(track.signal, track.sample_rate, config=audio)
    cfg = EvalConfig()
    onsets = B.onsets(
        B.energy_bands(feats, audio=audio),
        rate_hz=RATE,
        delta=cfg.onset_delta,
        wait_s=cfg.onset_wait_s,
        window_s=cfg.onset_window_s,
    )
    assert len(onsets) >= 0.5 * len(feats) / RATE  # speech: several syllables a second
    return onsets


def _motion_stopping_at(frames: np.ndarray, n: int) -> np.ndarray:
    """Angles `(n, 11)` whose speed is the distance (s) to the nearest of `frames`."""
    t = np.arange(n)
    speed = np.abs(t[:, None] - frames[None, :]).min(axis=1) / RATE
    angles = np.zeros((n, 11))
    angles[:, 3] = np.concatenate([[0.0], np.cumsum(speed[1:]) / RATE])  # step i → i+1: speed[i+1]
    return angles


def test_motion_on_the_onsets_is_more_consistent_than_shifted(speech_onsets: np.ndarray) -> None:
    sigma, n = EvalConfig().beat_sigma_s, int(speech_onsets.max()) + 100
    shift = int(np.median(np.diff(speech_onsets)) // 2)  # halfway between onsets

    def score(motion: np.ndarray) -> float:
        m = B.motion_beats(motion, rate_hz=RATE, order_s=0.05)
        bc = B.beat_consistency(
            audio_beats_s=speech_onsets / RATE, motion_beats_s=m / RATE, sigma_s=sigma
        )
        assert bc is not None
        return bc

    on, off = (
        score(_motion_stopping_at(speech_onsets, n)),
        score(_motion_stopping_at(speech_onsets + shift, n)),
    )
    assert on > 0.99 and on > off


# --------------------------------------------------------------------------------------------------
# FGD


def test_frechet_distance_of_an_affine_image(rng: np.random.Generator) -> None:
    x = rng.normal(size=(500, 4)) @ rng.normal(size=(4, 4))
    # y = 2x + 3: ‖μ − (2μ + 3)‖² = ‖μ + 3‖², Tr(Σ + 4Σ − 2·2Σ) = Tr Σ
    want = np.sum((x.mean(axis=0) + 3) ** 2) + np.trace(np.cov(x, rowvar=False))
    assert F.frechet_distance(real=x, generated=2 * x + 3) == pytest.approx(want, rel=1e-8)
    assert F.frechet_distance(real=x, generated=x) == pytest.approx(0.0, abs=1e-8)


def test_chunks_are_resampled_windows_of_known_stretches() -> None:
    cfg = EvalConfig(fgd_chunk_s=1.0, fgd_rate_hz=20.0, fgd_stride_s=0.5)
    run = np.repeat(np.arange(250, dtype=np.float64)[:, None], 11, axis=1)
    c = F.chunks([run, run[:80]], rate_hz=RATE, config=cfg)  # the 0.8 s stretch gives none
    assert c.shape == (4, 20, 11)  # starts 0, 50, 100, 150
    np.testing.assert_allclose(c[1, [0, -1], 0], [50.0, 149.0])


@pytest.fixture(scope="module")
def natural_chunks(synthetic_dataset: Path) -> tuple[np.ndarray, np.ndarray]:
    ds = gds.open(synthetic_dataset)
    cfg = EvalConfig()
    train, test = (
        F.chunks(
            known_runs(load_segments(ds, split_items(ds, variant="si", part=part, fold=0))),
            rate_hz=RATE,
            config=cfg,
        )
        for part in ("train", "test")
    )
    return train, test


def test_fgd_is_zero_for_itself_grows_with_noise_and_is_versioned(
    natural_chunks: tuple[np.ndarray, np.ndarray], tmp_path: Path, rng: np.random.Generator
) -> None:
    train, test = natural_chunks
    cfg = EvalConfig(fgd_epochs=15)
    model = F.feature_model(tmp_path, key="si-fold00", natural=train, config=cfg, seed=0, threads=1)
    assert model.fgd(real=test, generated=test) <= 1e-6
    noisy = [
        model.fgd(real=test, generated=test + rng.normal(0, s, test.shape).astype(np.float32))
        for s in (0.01, 0.03, 0.1, 0.3)
    ]
    assert all(a < b for a, b in pairwise(noisy)), noisy
    info = json.loads((tmp_path / "fgd" / "si-fold00" / "fgd.json").read_text())
    assert info["version"] == model.version and info["chunks"] == len(train)
    weights = tmp_path / "fgd" / "si-fold00" / "weights.pt"
    stamp = weights.stat().st_mtime_ns
    again = F.feature_model(tmp_path, key="si-fold00", natural=train, config=cfg, seed=0, threads=1)
    assert again.version == model.version and weights.stat().st_mtime_ns == stamp  # reused
    assert again.fgd(real=test, generated=test + 0.1) == pytest.approx(
        model.fgd(real=test, generated=test + 0.1)
    )
    other = F.feature_model(
        tmp_path, key="si-fold00", natural=train[1:], config=cfg, seed=0, threads=1
    )
    assert other.version != model.version  # other training data: another autoencoder


# --------------------------------------------------------------------------------------------------
# Baselines


def test_the_shuffled_clip_lends_another_clips_motion() -> None:
    def seg(clip: str, n: int, value: float, start: int = 0) -> Segment:
        angles = np.full((n, 11), value, np.float32)
        return make_segment(
            clip,
            subject="s",
            start=start,
            audio=np.zeros((n, 2)),
            angles01=np.full((n, 11), 0.5),
            angles=angles,
        )

    a, b, c = seg("a", 10, 1.0), seg("b", 6, 2.0), seg("c", 10, 3.0)
    out = shuffled_clip([a, b], [a, b], seed=0)
    np.testing.assert_array_equal(out[0][:6], 2.0)  # a gets b's motion …
    assert np.isnan(out[0][6:]).all()  # … unknown past b's end
    np.testing.assert_array_equal(out[1], 1.0)  # b gets a's, cut to length
    donors = {float(shuffled_clip([a], [a, b, c], seed=k)[0][0, 0]) for k in range(20)}
    assert donors == {2.0, 3.0}  # never its own clip
    alone = shuffled_clip([a], [a], seed=0)[0]
    assert np.isnan(alone).all()  # no other clip, no other piece: nothing to lend
    piece = shuffled_clip([a], [a, seg("a", 10, 5.0, start=10)], seed=0)[0]
    np.testing.assert_array_equal(piece, 5.0)  # another piece of the same clip
