"""How well a person's motion follows the speech: the main-speaker score's speech term.

v(t) is the person's head-and-hand speed (mean speed of nose and both wrists, in shoulder widths
per second, so neither the person's size in the image nor the frame rate matters); e(t) is the
RMS envelope of the audio centred on each frame's timestamp. Both are smoothed over SMOOTH_S, so
that syllable flicker does not dominate the slower rhythm gestures share with speech; their
normalised cross-correlation over windows is maximised over one lag (see `speech_following`).
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from gesturebank.skeletons import COCO17, get_skeleton

if TYPE_CHECKING:  # only for annotations: no video decoder needed
    from gesturebank.audio.io import Audio

HEAD_HANDS = ("nose", "left_wrist", "right_wrist")
MAX_LAG_S = 0.3  # largest motion–speech lag searched, either way
SMOOTH_S = 0.2  # width of the envelope's RMS window and of the speed's moving mean
SILENCE_RMS = 1e-4  # −80 dBFS: an envelope varying less than this has no speech to follow
_MIN_PAIRS = 4  # fewest frames a window's correlation is computed on


def frame_step(ts: np.ndarray) -> float:
    """Typical frame interval, seconds (1/30 s when there are too few frames to tell)."""
    steps = np.diff(ts)
    return float(np.median(steps)) if len(steps) else 1 / 30


def _moving_mean(x: np.ndarray, n: int) -> np.ndarray:
    """Centred mean of `x (T,)` over `n` frames, ignoring NaN; NaN where under half are finite."""
    n = min(n, len(x) - (1 - len(x) % 2))  # odd and no longer than x, so "same" keeps the length
    if n <= 1:
        return x
    ok = np.isfinite(x)
    kernel = np.ones(n)
    total = np.convolve(np.where(ok, x, 0.0), kernel, mode="same")
    count = np.convolve(ok.astype(np.float64), kernel, mode="same")
    return np.where(ok & (count >= n / 2), total / np.maximum(count, 1.0), np.nan)


def _smoothing_frames(ts: np.ndarray, smooth_s: float) -> int:
    return max(1, round(smooth_s / frame_step(ts)) | 1)


def head_hand_speed(
    *, keypoints: np.ndarray, timestamps: np.ndarray, skeleton: str, smooth_s: float = SMOOTH_S
) -> np.ndarray:
    """(T,) mean speed of nose and both wrists of one person, shoulder widths per second.

    keypoints: (T, K, 3) in `skeleton` order, NaN where unseen; timestamps: (T,) s. The speed
    is the central difference on the real timestamps, divided by the person's median shoulder
    width, then a centred moving mean over `smooth_s`. NaN where the person (or all three
    joints) is unseen, or no shoulder width is known.
    """
    ts = np.asarray(timestamps, dtype=np.float64)
    if len(ts) < 2:
        return np.full(len(ts), np.nan)
    coco = get_skeleton(skeleton).convert(keypoints, COCO17).astype(np.float64)
    xy = coco[:, [COCO17.index[j] for j in HEAD_HANDS], :2]  # (T, 3, 2)
    shoulders = (
        coco[:, COCO17.index["left_shoulder"], :2] - coco[:, COCO17.index["right_shoulder"], :2]
    )
    widths = np.linalg.norm(shoulders, axis=-1)
    if not np.isfinite(widths).any():
        return np.full(len(ts), np.nan)
    width = max(float(np.nanmedian(widths)), 1.0)
    speed = np.linalg.norm(np.gradient(xy, ts, axis=0), axis=-1)  # (T, 3) px/s; NaN next to gaps
    with warnings.catch_warnings():  # frames with all three joints unseen stay NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        mean = np.nanmean(speed, axis=1) / width
    return _moving_mean(mean, _smoothing_frames(ts, smooth_s))


def speech_envelope(
    *, audio: Audio, timestamps: np.ndarray, smooth_s: float = SMOOTH_S
) -> np.ndarray:
    """(T,) RMS of the audio over `smooth_s` centred on each frame's timestamp.

    Sample n of `audio` plays at `audio.start_s + n / sample_rate` on the frames' clock. The
    signal is first reduced to the mean power of 10 ms blocks (cheap for hour-long takes). NaN
    for frames whose window holds no audio.
    """
    ts = np.asarray(timestamps, dtype=np.float64)
    x = np.asarray(audio.signal, dtype=np.float32).reshape(-1)
    hop = max(1, audio.sample_rate // 100)
    n_blocks = len(x) // hop
    if n_blocks == 0:
        return np.full(len(ts), np.nan)
    blocks = x[: n_blocks * hop].reshape(n_blocks, hop)
    power = np.einsum("ij,ij->i", blocks, blocks, dtype=np.float64) / hop
    cum = np.concatenate([[0.0], np.cumsum(power)])
    centres = audio.start_s + (np.arange(n_blocks) + 0.5) * hop / audio.sample_rate
    lo = np.searchsorted(centres, ts - smooth_s / 2, side="left")
    hi = np.searchsorted(centres, ts + smooth_s / 2, side="right")
    n = hi - lo
    mean_power = (cum[hi] - cum[lo]) / np.maximum(n, 1)
    return np.where(n > 0, np.sqrt(np.maximum(mean_power, 0.0)), np.nan)


def _window_bounds(ts: np.ndarray, window_s: float) -> list[tuple[int, int]]:
    """Frame ranges of windows `window_s` long covering `ts`, overlapping by at least half."""
    end = ts[-1] + frame_step(ts)
    span = end - ts[0]
    n = 1 if span <= window_s else int(np.ceil((span - window_s) / (window_s / 2))) + 1
    starts = np.linspace(ts[0], max(ts[0], end - window_s), n)
    lo = np.searchsorted(ts, starts, side="left")
    hi = np.searchsorted(ts, starts + window_s, side="left")
    return [(int(a), int(b)) for a, b in zip(lo, hi, strict=True) if b > a]


def speech_following(
    *,
    speed: np.ndarray,
    envelope: np.ndarray,
    timestamps: np.ndarray,
    window_s: float,
    max_lag_s: float = MAX_LAG_S,
) -> float:
    """How well one person's motion follows the speech over a span, in [0, 1].

    speed, envelope: (T,) on the same frames (`head_hand_speed`, `speech_envelope`), NaN =
    unknown; timestamps: (T,) s. Per window, the normalised cross-correlation of speed at t
    with envelope at t + ℓ for every |ℓ| ≤ max_lag_s (in frames of the median interval); its
    mean over the windows with varying audio and the person seen in at least half the frames;
    the best lag's value, clipped at 0, times min(1, time those windows cover / window_s).
    0 when there is no such window.
    """
    ts = np.asarray(timestamps, dtype=np.float64)
    m = np.asarray(speed, dtype=np.float64)
    e = np.asarray(envelope, dtype=np.float64)
    if len(ts) < _MIN_PAIRS:
        return 0.0
    lag = round(max_lag_s / frame_step(ts))
    padded = np.full(len(e) + 2 * lag, np.nan)
    padded[lag : lag + len(e)] = e
    shifted = sliding_window_view(padded, len(e))  # (2·lag + 1, T): row j = e(t + j − lag)
    rows = []
    used = np.zeros(len(ts), bool)
    for lo, hi in _window_bounds(ts, window_s):
        mw, ew = m[lo:hi], shifted[:, lo:hi]
        seen = np.isfinite(mw)
        env = e[lo:hi][np.isfinite(e[lo:hi])]
        if seen.sum() < max(_MIN_PAIRS, (hi - lo) / 2) or env.size < _MIN_PAIRS:
            continue
        if float(np.ptp(env)) < SILENCE_RMS:
            continue  # silence: nothing to follow here, for anybody
        rows.append(_masked_ncc(mw, ew))
        used[lo:hi] = True
    if not rows:
        return 0.0
    with warnings.catch_warnings():  # a lag no window could use stays NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        curve = np.nanmean(np.stack(rows), axis=0)  # (2·lag + 1,) mean correlation per lag
    if not np.isfinite(curve).any():
        return 0.0
    # One lag per person and span (a speaker's timing is steady): choosing it once, rather than
    # per window, gives unrelated motion less chance to look correlated.
    best = float(np.clip(np.nanmax(curve), 0.0, 1.0))
    # Less than one window of evidence counts proportionally less (a 1 s span correlates by luck).
    return best * min(1.0, float(used.sum()) * frame_step(ts) / window_s)


def _masked_ncc(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(L,) normalised correlation of `a (n,)` with each row of `b (L, n)` over the frames
    finite in both; NaN for rows with fewer than _MIN_PAIRS, 0 where either side is constant."""
    ok = np.isfinite(a)[None, :] & np.isfinite(b)
    count = ok.sum(axis=1)
    n = np.maximum(count, 1)
    a2 = np.where(ok, a[None, :], 0.0)
    b2 = np.where(ok, b, 0.0)
    da = np.where(ok, a2 - (a2.sum(axis=1) / n)[:, None], 0.0)
    db = np.where(ok, b2 - (b2.sum(axis=1) / n)[:, None], 0.0)
    den = np.sqrt((da**2).sum(axis=1) * (db**2).sum(axis=1))
    r = np.where(den > 1e-12, (da * db).sum(axis=1) / np.maximum(den, 1e-12), 0.0)
    return np.where(count >= _MIN_PAIRS, r, np.nan)
