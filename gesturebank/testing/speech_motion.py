"""A generated dataset where motion is a known function of the audio (tests, benchmarks, demos).

Each take has a speech-like loudness envelope e(t) ∈ [0, 1] (random syllables, ~4 per second,
with pauses). Its "audio features" `(N, F)` are e(t) through a fixed random gain per feature,
plus a per-subject offset and gain and some noise — so per-subject z-normalisation matters. The
motion follows the envelope with memory: m(t) = the envelope through a first-order low-pass
(time constant `tau_s`), delayed by `lag_s`; the arms and head move with m, the other joints
stay put. The angles are then made playable, as the builder makes a person's: the dissertation's
low-pass (§4.2.3) and the robot's joint speed, since every written clip must hold the
invariants (`qc.invariants`: a syllable's 60 ms rise is several times faster than a shoulder).
The raw angles stored are the targets before that.
A frame-wise model sees only e(t) and cannot know m(t); a recurrent one can.

Each take is one clip, written with the real store and `datasets.refresh` (`testing.clips`), so
the result is a dataset folder like any built one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gesturebank.config import Config, ProcessingConfig
from gesturebank.filters import butter_lowpass
from gesturebank.robot import pepper
from gesturebank.robot.reach import speed_limit
from gesturebank.testing.clips import clip_from_targets, write_dataset

RATE_HZ = 100.0
# Normalised pose = REST + GAIN · signal; joints not listed stay at 0.5.
_INSTANT = {  # follow e(t)
    "LShoulderPitch": (0.75, -0.35),
    "RShoulderPitch": (0.75, -0.35),
    "LElbowRoll": (0.70, -0.40),
    "RElbowRoll": (0.30, 0.40),
}
_DELAYED = {  # follow m(t)
    "HeadPitch": (0.40, 0.25),
    "HeadYaw": (0.40, 0.25),
    "LShoulderRoll": (0.20, 0.25),
    "RShoulderRoll": (0.80, -0.25),
}


def envelope(n: int, rng: np.random.Generator) -> np.ndarray:
    """(n,) speech-like loudness in [0, 1]: ~4 syllables/s of random strength, with pauses."""
    onsets = rng.random(n) < 4.0 / RATE_HZ
    onsets &= np.repeat(rng.random(n // 150 + 1) < 0.8, 150)[:n]  # 1.5 s pauses, 20 % of the time
    pulses = onsets * rng.uniform(0.3, 1.0, n)
    kernel = np.hanning(13)  # ~120 ms syllable
    return np.clip(np.convolve(pulses, kernel, mode="same"), 0.0, 1.0)


def motion(env: np.ndarray, tau_s: float, *, lag_s: float) -> np.ndarray:
    """(n,) the envelope through a first-order low-pass of time constant tau_s, lag_s late."""
    alpha = 1.0 - np.exp(-1.0 / (tau_s * RATE_HZ))
    m = np.empty_like(env)
    acc = 0.0
    for i, v in enumerate(env):
        acc += alpha * (v - acc)
        m[i] = acc
    lag = round(lag_s * RATE_HZ)
    m = np.concatenate([np.zeros(lag), m[: len(m) - lag]]) if lag else m
    return np.clip(m / 0.5, 0.0, 1.0)  # the low-passed envelope rarely exceeds 0.5


def _playable(angles01: np.ndarray, profile: pepper.RobotProfile) -> np.ndarray:
    """`angles01 (n, 11)` low-passed as processing does and held within the joint speeds."""
    p = ProcessingConfig()
    angles = pepper.denormalise(angles01, profile)
    smooth = butter_lowpass(angles, RATE_HZ, cutoff_hz=p.cutoff_hz, order=p.butter_order)
    slow = speed_limit(smooth, np.asarray(profile.velocity) / RATE_HZ)
    return np.clip(pepper.normalise(slow, profile), 0.0, 1.0)


def write_speech_motion_dataset(
    out: Path,
    *,
    subjects: int = 4,
    takes_per_subject: int = 2,
    seconds: float = 12.0,
    n_features: int = 26,
    tau_s: float = 0.25,
    lag_s: float = 0.1,
    unknown_s: float = 0.5,
    seed: int = 0,
) -> Path:
    """Write the dataset into `out` and return it; SI folds = `subjects` (one per subject).

    Every take has `unknown_s` seconds of unknown pose (NaN angles) in its middle.
    """
    rng = np.random.default_rng(seed)
    gains = rng.uniform(0.5, 2.0, n_features)
    profile = pepper.load_profile(pepper.DEFAULT_PROFILE)
    n = round(seconds * RATE_HZ)
    takes = {}
    for s in range(subjects):
        subject = f"s{s}"
        offset = rng.normal(0.0, 3.0, n_features)
        scale = rng.uniform(0.5, 2.0)
        for k in range(takes_per_subject):
            take_id = f"{subject}__take{k}"
            env = envelope(n, rng)
            audio = offset + scale * np.outer(env, gains) + rng.normal(0.0, 0.05, (n, n_features))
            m = motion(env, tau_s, lag_s=lag_s)
            angles01 = np.full((n, len(pepper.JOINTS)), 0.5)
            for joint, (rest, gain) in _INSTANT.items():
                angles01[:, pepper.INDEX[joint]] = rest + gain * env
            for joint, (rest, gain) in _DELAYED.items():
                angles01[:, pepper.INDEX[joint]] = rest + gain * m
            gap = round(unknown_s * RATE_HZ)
            angles01[n // 2 : n // 2 + gap] = np.nan
            clip = clip_from_targets(
                _playable(angles01, profile),
                audio,
                clip_id=f"{take_id}__c000",
                profile=profile,
                raw01=angles01,
            )
            takes[take_id] = [clip]
    # Judged by the real QC, which would reject this motion (not a person's: it holds still
    # exactly in every pause of the speech), so its thresholds are opened for it.
    qc = {"max_jitter_fraction": 1.0, "max_frozen_fraction": 1.0, "outlier_z": 1e9}
    config = Config.model_validate({"splits": {"folds": max(2, subjects)}, "qc": qc})
    subject_of = {t: t.split("__")[0] for t in takes}
    return write_dataset(Path(out), takes, subjects=subject_of, config=config)
