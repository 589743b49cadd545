"""Audio decoding: a video's track or a .wav, averaged to mono, resampled with anti-aliasing,
placed on the video's clock."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import av
import numpy as np
import pytest
from scipy.io import wavfile
from scipy.signal import resample_poly

from gesturebank.audio.io import read_audio


def test_wav_is_read_sample_for_sample_at_its_own_rate(samples: Path) -> None:
    wav = samples / "speech" / "arctic_a0007.wav"
    rate, pcm = wavfile.read(wav)
    audio = read_audio(wav, sample_rate=rate)
    assert audio is not None
    assert audio.start_offset_s == 0.0 and audio.start_s == 0.0  # no video to be offset from
    np.testing.assert_array_equal(audio.signal, pcm / np.float32(32768))


def test_video_without_audio_gives_none(samples: Path) -> None:
    silent = samples / "pose2sim" / "Demo_SinglePerson" / "videos" / "cam01.mp4"
    assert read_audio(silent, sample_rate=16000) is None


def _amplitude(x: np.ndarray, freq: float, sr: int) -> float:
    """Amplitude of the `freq` component of x (lock-in detection)."""
    t = np.arange(len(x)) / sr
    return float(
        2
        * np.hypot(
            np.mean(x * np.sin(2 * np.pi * freq * t)), np.mean(x * np.cos(2 * np.pi * freq * t))
        )
    )


def _mux_audio(
    path: Path, audio: np.ndarray, rate: int, codec: str, audio_start_s: float = 0.0
) -> None:
    """A 1 s grey video plus `audio` (C, N) float in [-1, 1] starting at audio_start_s."""
    channels = audio.shape[0]
    with av.open(str(path), "w") as out:
        v = out.add_stream("libx264", rate=25)
        v.width, v.height, v.pix_fmt = 32, 32, "yuv420p"
        a = out.add_stream(codec, rate=rate, layout="stereo" if channels == 2 else "mono")
        for i in range(25):
            frame = av.VideoFrame.from_ndarray(np.full((32, 32, 3), 128, np.uint8), "rgb24")
            frame.pts, frame.time_base = i, Fraction(1, 25)
            out.mux(v.encode(frame))
        out.mux(v.encode())
        pcm = np.round(np.clip(audio, -1, 1) * 32767).astype(np.int16)
        start = round(audio_start_s * rate)
        chunk = 1024
        fmt = "s16p" if codec == "pcm_s16le" else "s16"
        for i in range(0, pcm.shape[1], chunk):
            block = pcm[:, i : i + chunk]
            data = block if fmt == "s16p" else block.T.reshape(1, -1)
            frame = av.AudioFrame.from_ndarray(
                np.ascontiguousarray(data), format=fmt, layout=a.layout.name
            )
            frame.sample_rate, frame.pts, frame.time_base = rate, start + i, Fraction(1, rate)
            out.mux(a.encode(frame))
        out.mux(a.encode())


def test_audio_is_averaged_resampled_with_antialiasing_and_offset(tmp_path: Path) -> None:
    sr_in, dur = 48000, 1.0
    t = np.arange(int(sr_in * dur)) / sr_in
    tone = np.sin(2 * np.pi * 440 * t)
    high = 0.3 * np.sin(2 * np.pi * 12000 * t)  # above 8 kHz: must not alias to 4 kHz
    stereo = np.stack([0.6 * tone + high, 0.2 * tone + high])
    path = tmp_path / "tone.mkv"
    _mux_audio(path, stereo, sr_in, "pcm_s16le", audio_start_s=0.5)
    audio = read_audio(path, sample_rate=16000)
    assert audio is not None
    x = audio.signal
    assert audio.sample_rate == 16000 and x.dtype == np.float32 and x.ndim == 1
    assert len(x) == pytest.approx(16000 * dur, abs=32)
    assert audio.start_offset_s == pytest.approx(0.5, abs=1e-3)
    assert audio.start_s == pytest.approx(0.5, abs=1e-3)  # the video starts at 0
    core = x[800:-800]  # away from the filter's edges
    assert _amplitude(core, 440, 16000) == pytest.approx(0.4, abs=0.01)  # (0.6 + 0.2) / 2
    assert _amplitude(core, 4000, 16000) < 0.005  # the 12 kHz tone was filtered, not folded


def test_speech_muxed_as_aac_matches_the_wav(tmp_path: Path, samples: Path) -> None:
    wav = samples / "speech" / "arctic_a0007.wav"
    with av.open(str(wav)) as c:
        ref = np.concatenate([f.to_ndarray().reshape(-1) for f in c.decode(audio=0)])
        sr_ref = c.streams.audio[0].rate
    ref = ref.astype(np.float64) / 32768 if ref.dtype == np.int16 else ref.astype(np.float64)
    up = resample_poly(ref, 44100, sr_ref)  # muxed at 44.1 kHz stereo like a camera would
    path = tmp_path / "speech.mp4"
    _mux_audio(path, np.stack([up, up]), 44100, "aac")
    audio = read_audio(path, sample_rate=16000)
    assert audio is not None
    ref16 = resample_poly(ref, 16000, sr_ref)
    n = min(len(ref16), len(audio.signal))
    assert abs(len(audio.signal) - len(ref16)) < 0.05 * 16000
    a, b = audio.signal[:n], ref16[:n]
    lags = range(-160, 161)
    corr = [np.corrcoef(np.roll(a, lag), b)[0, 1] for lag in lags]
    best = int(np.argmax(corr))
    assert corr[best] > 0.95
    # Sample 0 plays at the offset: the aligned lag plus the offset stays within 10 ms of 0.
    assert abs(list(lags)[best] / 16000 + audio.start_offset_s) < 0.01
