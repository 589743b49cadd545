"""Time offsets between unsynchronised cameras, and putting their keypoints on one clock.

Convention: the offset of camera c is `offset_s[c] = t_c − t_ref`, the time on camera c's clock
minus the time on the reference camera's clock of the same event (0 for the reference). So a
frame stamped `t` by camera c happened at `t − offset_s[c]` on the reference clock.

Audio is the precise cue: every camera's microphone hears the same sound, and the lag that
maximises the cross-correlation of two tracks is their offset to the sample. Without audio, the
speed of the 2D keypoints is the cue (a person's motion starts and stops at the same instants in
every view), good to about one frame.
"""

from __future__ import annotations

import logging
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import signal as sps

from gesturebank.audio.io import Audio
from gesturebank.errors import InputError
from gesturebank.poses import Pose2D

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Lag:
    """A lag found by cross-correlation: seconds, and the normalised peak height in [-1, 1]
    (≈ 1 for copies of the same signal; below ~0.2 the estimate is not trustworthy)."""

    seconds: float
    score: float


def signal_lag(
    reference: np.ndarray,
    other: np.ndarray,
    *,
    rate: float,
    max_lag_s: float | None = None,
    min_overlap: float = 0.5,
) -> Lag:
    """Delay of `other` behind `reference`: other(t) ≈ reference(t − lag).

    reference (N,), other (M,): uniformly sampled signals at `rate` Hz (NaN counts as 0).
    max_lag_s: search only |lag| ≤ this. min_overlap: fewest overlapping samples at a lag, as a
    fraction of the shorter signal. The score at each lag is the Pearson correlation over the
    overlap only, so short overlaps are neither favoured nor penalised (this matters for clips
    of a few seconds). Integer-sample precision.
    """
    a = np.nan_to_num(np.asarray(reference, np.float64).ravel())
    b = np.nan_to_num(np.asarray(other, np.float64).ravel())
    if a.size < 2 or b.size < 2:
        raise InputError("signal_lag: signals need at least 2 samples")
    a, b = a - a.mean(), b - b.mean()  # better conditioned sums below
    # Σ a[n] b[n + k] for every lag k by FFT; the overlap's own sums from cumulative sums.
    sxy = sps.correlate(b, a, mode="full", method="fft")
    lags = sps.correlation_lags(b.size, a.size, mode="full")
    n0 = np.maximum(0, -lags)
    n1 = np.minimum(a.size, b.size - lags)
    count = np.maximum(n1 - n0, 1)
    ca, ca2, cb, cb2 = (_cumsum(x) for x in (a, a * a, b, b * b))
    sx, sxx = ca[n1] - ca[n0], ca2[n1] - ca2[n0]
    sy, syy = cb[n1 + lags] - cb[n0 + lags], cb2[n1 + lags] - cb2[n0 + lags]
    cov = sxy - sx * sy / count
    var = np.maximum(sxx - sx * sx / count, 0) * np.maximum(syy - sy * sy / count, 0)
    tiny = 1e-12 * float(a @ a) * float(b @ b)
    r = np.divide(cov, np.sqrt(var), out=np.zeros_like(cov), where=var > tiny)
    keep = (n1 - n0) >= max(2, int(min_overlap * min(a.size, b.size)))
    if max_lag_s is not None:
        keep &= np.abs(lags) <= max_lag_s * rate
    if not keep.any():
        raise InputError("signal_lag: no lag leaves enough overlap; raise max_lag_s")
    r = np.where(keep, r, -np.inf)
    best = int(np.argmax(r))
    return Lag(seconds=float(lags[best]) / rate, score=float(r[best]))


def _cumsum(x: np.ndarray) -> np.ndarray:
    """(N + 1,) running sums with a leading 0, so sum(x[i:j]) = c[j] − c[i]."""
    return np.concatenate([[0.0], np.cumsum(x)])


def audio_offset(
    reference: Audio,
    other: Audio,
    *,
    max_lag_s: float | None = 2.0,
    reference_start_s: float = 0.0,
    other_start_s: float = 0.0,
) -> Lag:
    """Offset (camera clock of `other` minus that of `reference`) from the two audio tracks.

    Each Audio's `start_offset_s` places its first sample relative to its video's first frame;
    `*_start_s` are the timestamps of those first frames (0 for most files).
    """
    if reference.sample_rate != other.sample_rate:
        raise InputError(
            f"audio_offset: sample rates differ ({reference.sample_rate} vs {other.sample_rate})"
        )
    lag = signal_lag(
        reference.signal, other.signal, rate=reference.sample_rate, max_lag_s=max_lag_s
    )
    # Sample n of a track sits at video_start + start_offset + n / sr on its camera's clock.
    shift = (other_start_s + other.start_offset_s) - (reference_start_s + reference.start_offset_s)
    return Lag(seconds=lag.seconds + shift, score=lag.score)


def motion_signal(
    pose: Pose2D, rate: float, *, min_confidence: float = 0.5, cutoff_hz: float = 6.0
) -> tuple[np.ndarray, np.ndarray]:
    """Vertical keypoint velocity of one view on a uniform clock: (times (N,), velocity (N,)).

    Per frame, the median over confident keypoints of dy/dt, in person heights per second:
    the median ignores the odd keypoint that jumps, and vertical motion (a lunge, a nod, a
    raised arm) looks alike from every upright camera, which total speed does not. Resampled
    at `rate` Hz and low-passed at `cutoff_hz` (zero-phase 4th-order Butterworth) against
    detector jitter.
    """
    ts = pose.timestamps
    if len(ts) < 3:
        raise InputError("motion_signal: need at least 3 frames")
    y = pose.keypoints[..., 1].astype(np.float64)
    y[~(pose.keypoints[..., 2] >= min_confidence)] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # frames without keypoints → NaN
        height = np.nanmedian(np.nanmax(y, axis=1) - np.nanmin(y, axis=1))
        vy = np.nanmedian(np.diff(y, axis=0), axis=1) / np.diff(ts)
    vy /= height if np.isfinite(height) and height > 0 else 1.0
    mid = (ts[1:] + ts[:-1]) / 2
    ok = np.isfinite(vy)
    if ok.sum() < 2:
        raise InputError("motion_signal: the person is missing in almost every frame")
    grid = np.arange(mid[0], mid[-1], 1.0 / rate)
    v = np.interp(grid, mid[ok], vy[ok])
    if cutoff_hz < rate / 2 and v.size > 30:  # filtfilt needs a few filter lengths of data
        b, a = sps.butter(4, cutoff_hz / (rate / 2))
        v = sps.filtfilt(b, a, v)
    return grid, v


def motion_offset(
    reference: Pose2D, other: Pose2D, *, max_lag_s: float | None = 2.0, rate: float = 120.0
) -> Lag:
    """Offset (other's clock minus reference's) from the keypoint motion of the two views.

    `rate` (Hz) is the common grid both curves are resampled on, so cameras with different
    frame rates compare and the result is not rounded to a whole frame of either camera.
    """
    t_ref, s_ref = motion_signal(reference, rate)
    t_oth, s_oth = motion_signal(other, rate)
    lag = signal_lag(s_ref, s_oth, rate=rate, max_lag_s=max_lag_s)
    # The curves start at their own first timestamps; the lag counts from those starts.
    return Lag(seconds=lag.seconds + t_oth[0] - t_ref[0], score=lag.score)


def estimate_offsets(
    poses: Sequence[Pose2D],
    audios: Sequence[Audio | None] | None = None,
    *,
    method: str = "auto",
    reference: int = 0,
    max_lag_s: float = 2.0,
) -> tuple[np.ndarray, list[str], np.ndarray]:
    """Offsets of every camera against camera `reference`.

    method: 'audio', 'motion' or 'auto' (audio when both tracks exist, else motion).
    Returns (offsets_s (C,), method used per camera, scores (C,)).
    """
    C = len(poses)
    if not 0 <= reference < C:
        raise InputError(f"reference camera {reference} out of range for {C} cameras")
    audios = list(audios) if audios is not None else [None] * C
    if len(audios) != C:
        raise InputError(f"{len(audios)} audio tracks for {C} cameras")
    offsets, scores, used = np.zeros(C), np.ones(C), ["reference"] * C
    for c in range(C):
        if c == reference:
            continue
        a_ref, a_c = audios[reference], audios[c]
        have_audio = a_ref is not None and a_c is not None and a_ref.signal.size and a_c.signal.size
        if method == "audio" and not have_audio:
            raise InputError(f"camera {c}: audio sync asked for but a track is missing")
        if method in ("audio", "auto") and have_audio:
            assert a_ref is not None and a_c is not None
            lag = audio_offset(
                a_ref,
                a_c,
                max_lag_s=max_lag_s,
                reference_start_s=float(poses[reference].timestamps[0]),
                other_start_s=float(poses[c].timestamps[0]),
            )
            used[c] = "audio"
        elif method in ("motion", "auto"):
            lag = motion_offset(poses[reference], poses[c], max_lag_s=max_lag_s)
            used[c] = "motion"
        else:
            raise InputError(f"unknown sync method {method!r} (audio, motion, auto)")
        offsets[c], scores[c] = lag.seconds, lag.score
        log.info("camera %d: offset %+.4f s by %s (score %.2f)", c, lag.seconds, used[c], lag.score)
        if lag.score < 0.2:
            log.warning(
                "camera %d: weak %s correlation (%.2f); offset unreliable", c, used[c], lag.score
            )
    return offsets, used, scores


def align(
    poses: Sequence[Pose2D], offsets_s: Sequence[float] | np.ndarray, *, times: np.ndarray
) -> np.ndarray:
    """Keypoints of every view at the reference-clock `times` (T,): (C, T, K, 3).

    View c's frames are moved to the reference clock (t − offset_s[c]) and linearly
    interpolated; a time outside a view's frames, or between two frames of which one lacks the
    keypoint, or across a gap of more than 1.5 frames, gives NaN. Confidence is the smaller of
    the two neighbours'.
    """
    if len(offsets_s) != len(poses):
        raise InputError(f"{len(offsets_s)} offsets for {len(poses)} cameras")
    times = np.asarray(times, np.float64)
    out = []
    for pose, off in zip(poses, offsets_s, strict=True):
        out.append(_resample(pose.keypoints.astype(np.float64), pose.timestamps - off, times))
    return np.stack(out).astype(np.float32)


def _resample(kp: np.ndarray, ts: np.ndarray, times: np.ndarray) -> np.ndarray:
    """kp (T, K, 3) at ts (T,) → (len(times), K, 3) by linear interpolation (see `align`)."""
    n = len(ts)
    step = float(np.median(np.diff(ts))) if n > 1 else np.inf
    tol = 1e-6 * max(1.0, step if np.isfinite(step) else 1.0)
    hi = np.clip(np.searchsorted(ts, times), 0, n - 1)
    lo = np.clip(hi - 1, 0, n - 1)
    exact_hi = np.abs(ts[hi] - times) <= tol
    exact_lo = np.abs(ts[lo] - times) <= tol
    span = ts[hi] - ts[lo]
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha = np.where(span > 0, (times - ts[lo]) / span, 0.0)
    inside = (times >= ts[lo] - tol) & (times <= ts[hi] + tol) & (span <= 1.5 * step + tol)
    a = alpha[:, None, None]
    xy = (1 - a) * kp[lo, :, :2] + a * kp[hi, :, :2]
    conf = np.minimum(kp[lo, :, 2:], kp[hi, :, 2:])
    res = np.concatenate([xy, conf], axis=-1)
    res = np.where(exact_hi[:, None, None], kp[hi], res)
    res = np.where((exact_lo & ~exact_hi)[:, None, None], kp[lo], res)
    res[~(inside | exact_hi | exact_lo)] = np.nan
    return res
