"""Beat consistency (BEAT, Liu et al. 2022): do motion beats fall on the speech's onsets?

Score = 1/|B_a| Σ_{b ∈ B_a} exp(−d(b)² / 2σ²), d(b) the distance from audio beat b to the nearest
motion beat, σ = 0.3 s. In [0, 1]: 1 when every audio beat has a motion beat on it.

- Audio beats are onsets of the stored features, not of the waveform (the dataset keeps
  log-Mel energies at 100 Hz, no audio samples): onset strength is the spectral flux of the
  log-Mel bands — the mean over bands of the rise since the previous frame, librosa's
  `onset_strength` on a log spectrogram — normalised to [0, 1]; an onset is a local maximum
  that exceeds the local mean by `onset_delta`, at least `onset_wait_s` after the previous one,
  then moved back to the preceding minimum of the band energy (BEAT backtracks on RMS). For
  MFCC-13 the only energy column is the log frame energy (coefficient 0), whose rise is used.
- Motion beats are the local minima of the angular speed (norm over the 11 joints of
  the angle velocity): the moments a gesture stops or turns. BEAT used the right wrist's speed;
  Pepper angles have no wrist position, and every joint's stroke counts.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.ndimage import maximum_filter1d, minimum_filter1d, uniform_filter1d

from gesturebank.audio.features import feature_dim
from gesturebank.config import AudioConfig

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


def energy_bands(features: ArrayLike, *, audio: AudioConfig) -> F64:
    """The log-energy columns `(N, B)` of un-normalised audio features `(N, F)`.

    LogFB-26/52/78: the `nfilt` log-Mel bands (the deltas after them are left out); MFCC-13:
    the log frame energy that replaces coefficient 0.
    """
    f = np.asarray(features, dtype=np.float64)
    if f.ndim != 2 or f.shape[1] != feature_dim(audio):
        raise ValueError(f"expected ({feature_dim(audio)},)-feature frames, got {f.shape}")
    return f[:, :1] if audio.features == "mfcc13" else f[:, : audio.nfilt]


def onset_strength(bands: ArrayLike) -> F64:
    """Spectral flux `(N,)` of log-energy bands `(N, B)`: mean over bands of max(0, S_t − S_{t−1}).

    Frame 0 has no predecessor: 0.
    """
    s = np.asarray(bands, dtype=np.float64)
    rise = np.maximum(np.diff(s, axis=0), 0.0).mean(axis=1)
    return np.concatenate([[0.0], rise])


def onsets(
    bands: ArrayLike, *, rate_hz: float, delta: float, wait_s: float, window_s: float
) -> I64:
    """Onset frames of log-energy bands `(N, B)` (module docstring), ascending."""
    s = np.asarray(bands, dtype=np.float64)
    env = onset_strength(s)
    span = env.max() - env.min()
    if len(env) < 3 or span <= 0:
        return np.zeros(0, dtype=np.int64)
    env = (env - env.min()) / span
    w = max(1, round(window_s * rate_hz))
    is_max = env == maximum_filter1d(env, size=2 * w + 1, mode="nearest")
    above = env >= uniform_filter1d(env, size=2 * w + 1, mode="nearest") + delta
    wait = round(wait_s * rate_hz)
    picked: list[int] = []
    for t in np.flatnonzero(is_max & above & (env > 0)):
        if not picked or t - picked[-1] > wait:
            picked.append(int(t))
    energy = s.mean(axis=1)
    return np.unique(np.array([_backtrack(energy, t) for t in picked], dtype=np.int64))


def _backtrack(energy: F64, t: int) -> int:
    """The frame of the energy minimum just before onset `t` (walk back while it falls)."""
    while t > 0 and energy[t - 1] <= energy[t]:
        t -= 1
    return t


def motion_beats(angles: ArrayLike, *, rate_hz: float, order_s: float) -> I64:
    """Frames of the local minima of the angular speed of `(N, J)` angles, ascending.

    The speed at frame i is the central difference's norm. A minimum is the lowest speed within
    `order_s` on either side, but not of a motionless window (a held pose has no beat); of tied
    minima closer than that only the first counts. The clip's first and last frames are not
    beats (nothing is known beyond them).
    """
    a = np.asarray(angles, dtype=np.float64)
    if len(a) < 3:
        return np.zeros(0, dtype=np.int64)
    speed = np.linalg.norm(np.gradient(a, axis=0), axis=1) * rate_hz
    order = max(1, round(order_s * rate_hz))
    size = 2 * order + 1
    low = speed <= minimum_filter1d(speed, size=size, mode="nearest")
    moving = speed < maximum_filter1d(speed, size=size, mode="nearest")
    picked: list[int] = []
    for t in np.flatnonzero(low & moving):
        if 0 < t < len(a) - 1 and (not picked or t - picked[-1] > order):
            picked.append(int(t))
    return np.array(picked, dtype=np.int64)


def beat_scores(*, audio_beats_s: ArrayLike, motion_beats_s: ArrayLike, sigma_s: float) -> F64:
    """exp(−d²/2σ²) per audio beat, d = seconds to the nearest motion beat (0 without any)."""
    ab = np.asarray(audio_beats_s, dtype=np.float64).ravel()
    mb = np.sort(np.asarray(motion_beats_s, dtype=np.float64).ravel())
    if mb.size == 0:
        return np.zeros(ab.size)
    d = np.abs(ab[:, None] - mb[None, :]).min(axis=1)
    return np.exp(-(d**2) / (2 * sigma_s**2))


def beat_consistency(
    *, audio_beats_s: ArrayLike, motion_beats_s: ArrayLike, sigma_s: float
) -> float | None:
    """BEAT's score: the mean of `beat_scores`; None without audio beats (nothing to match)."""
    scores = beat_scores(
        audio_beats_s=audio_beats_s, motion_beats_s=motion_beats_s, sigma_s=sigma_s
    )
    return float(np.mean(scores)) if scores.size else None
