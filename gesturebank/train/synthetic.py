"""A generated dataset where motion is a known function of the audio (tests, benchmarks, demos).

Each take has a speech-like loudness envelope e(t) ∈ [0, 1] (random syllables, ~4 per second,
with pauses). Its "audio features" `(N, F)` are e(t) through a fixed random gain per feature,
plus a per-subject offset and gain and some noise — so per-subject z-normalisation matters. The
motion follows the envelope with memory: m(t) = the envelope through a first-order low-pass
(time constant `tau_s`), delayed by `lag_s`; the arms and head move with m, the other joints
stay put. A frame-wise model sees only e(t) and cannot know m(t); a recurrent one can.

The takes are written with the real store (`write_take`, `write_manifest`, `write_dataset_json`,
`write_splits`), so the result is a dataset folder like any built one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gesturebank.config import Config, SplitsConfig
from gesturebank.datasets import store
from gesturebank.datasets.splits import write_splits
from gesturebank.extract.audio import fit_znorm
from gesturebank.robot import pepper

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


def motion(env: np.ndarray, tau_s: float, lag_s: float) -> np.ndarray:
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


def write_synthetic_dataset(
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
    out = Path(out)
    rng = np.random.default_rng(seed)
    gains = rng.uniform(0.5, 2.0, n_features)
    profile = pepper.load_profile(pepper.DEFAULT_PROFILE)
    n = round(seconds * RATE_HZ)
    config = Config()
    digest = config.digest()
    feats_by_subject: dict[str, list[np.ndarray]] = {}
    for s in range(subjects):
        subject = f"s{s}"
        offset = rng.normal(0.0, 3.0, n_features)
        scale = rng.uniform(0.5, 2.0)
        for k in range(takes_per_subject):
            take_id = f"{subject}__take{k}"
            env = envelope(n, rng)
            audio = offset + scale * np.outer(env, gains) + rng.normal(0.0, 0.05, (n, n_features))
            m = motion(env, tau_s, lag_s)
            angles01 = np.full((n, len(pepper.JOINTS)), 0.5)
            for joint, (rest, gain) in _INSTANT.items():
                angles01[:, pepper.INDEX[joint]] = rest + gain * env
            for joint, (rest, gain) in _DELAYED.items():
                angles01[:, pepper.INDEX[joint]] = rest + gain * m
            gap = round(unknown_s * RATE_HZ)
            angles01[n // 2 : n // 2 + gap] = np.nan
            angles = pepper.denormalise(angles01, profile)
            record = store.TakeRecord(
                take_id=take_id,
                subject=subject,
                source=f"synthetic/{take_id}",
                qc_status="accepted",
                config_digest=digest,
                duration_s=n / RATE_HZ,
                n_frames=n,
            )
            arrays: dict[str, np.ndarray] = {
                "angles": angles.astype(np.float32),
                "angles01": angles01.astype(np.float32),
                "audio": audio.astype(np.float32),
                "times": np.arange(n) / RATE_HZ,
            }
            store.write_take(out, record, arrays)
            feats_by_subject.setdefault(subject, []).append(audio)
    table = store.write_manifest(out)
    stats = {}
    for subject, feats in feats_by_subject.items():
        mean, std = fit_znorm(feats)
        stats[subject] = {"mean": mean.tolist(), "std": std.tolist()}
    mean, std = fit_znorm([f for fs in feats_by_subject.values() for f in fs])
    stats["*"] = {"mean": mean.tolist(), "std": std.tolist()}
    store.write_dataset_json(
        out,
        {
            "tool": "gesturebank",
            "config": config.to_json_dict(),
            "joints": list(pepper.JOINTS),
            "limits": profile.as_dict(),
            "robot_profile": profile.name,
            "rates": {"pose_hz": RATE_HZ, "audio_hz": RATE_HZ},
            "audio_features": {"kind": "synthetic", "dim": n_features},
            "normalisation": {"audio_znorm_by_subject": stats},
        },
    )
    write_splits(out, table.to_pylist(), SplitsConfig(folds=subjects))
    return out
