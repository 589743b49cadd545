"""Tests of audio.features: reference equality on real speech, formulas, live path."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import python_speech_features as psf
from scipy.io import wavfile

from gesturebank.audio.features import (
    apply_znorm,
    delta,
    feature_dim,
    features,
    fit_znorm,
    frame_features,
    hz_to_mel,
    mel_to_hz,
    num_frames,
)
from gesturebank.config import AudioConfig
from gesturebank.errors import InputError

SR = 16000


def _read_wav(path: Path) -> np.ndarray:
    rate, raw = wavfile.read(path)
    assert rate == SR and raw.dtype == np.int16 and raw.ndim == 1
    return (raw / 32768.0).astype(np.float32)


def _psf_default(x: np.ndarray, kind: str) -> np.ndarray:
    """python_speech_features 0.6 called with its defaults only: the dissertation's features."""
    x64 = x.astype(np.float64)
    if kind == "mfcc13":
        return psf.mfcc(x64)
    fb = psf.logfbank(x64)
    parts = [fb]
    if kind in ("logfb52", "logfb78"):
        parts.append(psf.delta(fb, 2))
    if kind == "logfb78":
        parts.append(psf.delta(parts[1], 2))
    return np.hstack(parts)


def _psf_hamming(x: np.ndarray, kind: str) -> np.ndarray:
    """python_speech_features 0.6 with the dissertation's parameters and a Hamming window.

    Its `logfbank` takes no window argument, so LogFB is log(fbank(winfunc=hamming)), which is
    exactly what its logfbank computes with a rectangular window.
    """
    x64 = x.astype(np.float64)
    common = dict(
        samplerate=SR, winlen=0.025, winstep=0.01, nfilt=26, nfft=512, preemph=0.97,
        winfunc=np.hamming,
    )  # fmt: skip
    if kind == "mfcc13":
        return psf.mfcc(x64, numcep=13, **common)
    fb = np.log(psf.fbank(x64, **common)[0])
    parts = [fb]
    if kind in ("logfb52", "logfb78"):
        parts.append(psf.delta(fb, 2))
    if kind == "logfb78":
        parts.append(psf.delta(parts[1], 2))
    return np.hstack(parts)


@pytest.mark.media
@pytest.mark.parametrize("name", ["arctic_a0007", "arctic_a0009"])
@pytest.mark.parametrize("kind", ["logfb26", "logfb52", "logfb78", "mfcc13"])
def test_default_features_equal_python_speech_features_defaults_on_real_speech(
    samples: Path, name: str, kind: str
) -> None:
    # The default config (only the feature kind chosen) gives the dissertation's features.
    x = _read_wav(samples / "speech" / f"{name}.wav")
    got = features(x, SR, config=AudioConfig(features=kind))
    ref = _psf_default(x, kind)
    assert got.dtype == np.float32
    assert (
        got.shape
        == ref.shape
        == (num_frames(len(x), AudioConfig()), feature_dim(AudioConfig(features=kind)))
    )
    assert np.max(np.abs(got - ref)) <= 1e-4


@pytest.mark.media
@pytest.mark.parametrize("name", ["arctic_a0007", "arctic_a0009"])
@pytest.mark.parametrize("kind", ["logfb26", "logfb52", "logfb78", "mfcc13"])
def test_hamming_features_equal_python_speech_features_on_real_speech(
    samples: Path, name: str, kind: str
) -> None:
    x = _read_wav(samples / "speech" / f"{name}.wav")
    got = features(x, SR, config=AudioConfig(features=kind, window="hamming"))
    ref = _psf_hamming(x, kind)
    assert got.shape == ref.shape
    assert np.max(np.abs(got - ref)) <= 1e-4
    # The window matters: the default (rectangular) features are far from these.
    assert np.max(np.abs(features(x, SR, config=AudioConfig(features=kind)) - ref)) > 0.1


@pytest.mark.media
@pytest.mark.parametrize("window", ["none", "hamming"])
@pytest.mark.parametrize("kind", ["logfb26", "mfcc13"])
def test_live_frame_equals_batch_row_on_real_speech(samples: Path, kind: str, window: str) -> None:
    x = _read_wav(samples / "speech" / "arctic_a0007.wav")
    config = AudioConfig(features=kind, window=window)
    batch = features(x, SR, config=config)
    for i in [0, 1, 37, 150, len(batch) - 4]:
        start = i * 160
        prev = float(x[start - 1]) if start else 0.0
        row = frame_features(x[start : start + 400], SR, config=config, previous=prev)
        np.testing.assert_allclose(row, batch[i], atol=1e-5)


def test_live_frame_equals_batch_row_on_noise() -> None:
    x = np.random.default_rng(0).normal(scale=0.1, size=SR).astype(np.float32)
    config = AudioConfig()
    batch = features(x, SR, config=config)
    row = frame_features(
        x[50 * 160 : 50 * 160 + 400], SR, config=config, previous=float(x[50 * 160 - 1])
    )
    np.testing.assert_allclose(row, batch[50], atol=1e-5)
    # Without the sample before the window, pre-emphasis differs at the first sample only.
    assert not np.allclose(frame_features(x[8000:8400], SR, config=config), batch[50], atol=1e-5)


def test_live_frame_refuses_delta_features() -> None:
    with pytest.raises(InputError, match="future frames"):
        frame_features(np.zeros(400), SR, config=AudioConfig(features="logfb52"))


def test_frame_i_covers_samples_from_i_times_hop() -> None:
    # A click at sample s (pre-emphasis adds −0.97 at s + 1) is seen only by frames whose window
    # [160 i, 160 i + 400) holds s or s + 1; every other frame is digital silence (log eps).
    s = 1000
    x = np.zeros(SR)
    x[s] = 0.5
    fb = features(x, SR, config=AudioConfig())
    hit = np.flatnonzero(fb.max(axis=1) > np.log(np.finfo(np.float64).eps) + 1)
    expected = [i for i in range(len(fb)) if 160 * i <= s + 1 and s < 160 * i + 400]
    assert hit.tolist() == expected == [4, 5, 6]


def test_frame_count_and_dims() -> None:
    # 1 + ceil((S − 400) / 160) frames; F per kind.
    for n in (400, 401, 560, 561, SR):
        assert num_frames(n, AudioConfig()) == 1 + math.ceil((n - 400) / 160)
        assert features(np.ones(n) * 0.1, SR, config=AudioConfig()).shape == (
            num_frames(n, AudioConfig()),
            26,
        )
    dims = {
        k: feature_dim(AudioConfig(features=k)) for k in ("logfb26", "logfb52", "logfb78", "mfcc13")
    }
    assert dims == {"logfb26": 26, "logfb52": 52, "logfb78": 78, "mfcc13": 13}


def test_mel_scale_against_eq_3_4() -> None:
    # 1000 Hz ≈ 1000 mel by construction of the scale; Eq. 3.4's 1125·ln form agrees within 0.2 %.
    assert hz_to_mel(1000.0) == pytest.approx(1000.0, abs=0.1)
    f = np.array([100.0, 700.0, 4000.0, 8000.0])
    np.testing.assert_allclose(hz_to_mel(f), 1125 * np.log(1 + f / 700), rtol=2e-3)
    np.testing.assert_allclose(mel_to_hz(hz_to_mel(f)), f)


def test_delta_against_eq_3_5() -> None:
    # A line a + b·i has Δ = b inside; at the edges frames are repeated, so row 0 is
    # Σ n·(x[n] − x[0]) / (2 Σ n²) = (1·b + 2·2b) / 10 = b / 2; row 1 is (1·2b + 2·3b) / 10.
    b = 0.5
    feat = (3.0 + b * np.arange(10))[:, None] * np.ones((1, 2))
    d = delta(feat, 2)
    np.testing.assert_allclose(d[2:-2], b)
    np.testing.assert_allclose(d[0], b / 2)
    np.testing.assert_allclose(d[1], (1 * 2 * b + 2 * 3 * b) / 10)  # x[-1] repeats x[0]


def test_znorm_round_trip() -> None:
    rng = np.random.default_rng(2)
    takes = [rng.normal(3.0, 2.0, size=(200, 4)), rng.normal(3.0, 2.0, size=(50, 4))]
    takes[0][:, 3] = takes[1][:, 3] = 7.0  # a constant feature: std 0
    mean, std = fit_znorm(takes)
    allf = np.concatenate(takes)
    np.testing.assert_allclose(mean, allf.mean(axis=0))
    z = apply_znorm(allf, mean, std=std)
    np.testing.assert_allclose(z[:, :3].mean(axis=0), 0.0, atol=1e-6)
    np.testing.assert_allclose(z[:, :3].std(axis=0), 1.0, atol=1e-5)
    assert np.all(z[:, 3] == 0.0)  # floored, not NaN
    np.testing.assert_allclose(z * std + mean, allf, atol=1e-5)


@pytest.mark.parametrize(
    ("signal", "rate"),
    [
        (np.zeros((SR, 2)), SR),  # stereo
        (np.zeros(SR), 44100),  # not the configured rate
        (np.zeros(SR), float("nan")),
        (np.zeros(399), SR),  # shorter than one window
        (np.array([0.0] * 500 + [np.nan]), SR),
        (np.zeros(SR, dtype=np.int16), SR),  # PCM not converted to float
    ],
)
def test_features_reject_bad_input(signal: np.ndarray, rate: float) -> None:
    with pytest.raises(InputError):
        features(signal, rate, config=AudioConfig())


def test_znorm_rejects_mismatched_shapes() -> None:
    with pytest.raises(InputError):
        apply_znorm(np.zeros((5, 3)), np.zeros(4), std=np.ones(4))
    with pytest.raises(InputError):
        fit_znorm([np.zeros((5, 3)), np.zeros((5, 4))])
