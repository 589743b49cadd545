"""A generated dataset of two people talking in turn (tests of partners, the dyadic split, the
listener target and `live --role listener`).

Each take holds two people, 0 and 1, filmed over the whole take (one clip each, both from time
0, so they overlap and are paired by `datasets.partners`). They speak in turns of `turn_s`
seconds, person 0 first; the one audio track has a speech-like envelope e(t)
(`speech_motion.envelope`) throughout. The speaker's head follows e(t) as in
`speech_motion` (low-passed, a little late); the listener's head nods: its HeadPitch follows
e(t) through a slower low-pass, later (`listen_tau_s`, `listen_lag_s`), its HeadYaw stays
still. The arms rest. Role tracks say who speaks when.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from gesturebank.clip import Clip
from gesturebank.config import Config
from gesturebank.datasets.partners import LISTENING, SPEAKING, pair_clips
from gesturebank.robot import pepper
from gesturebank.testing.clips import clip_from_targets, write_dataset
from gesturebank.testing.speech_motion import RATE_HZ, _playable, envelope, motion


def with_person(clip: Clip, *, person: int, role: np.ndarray) -> Clip:
    """`clip` as person `person` with role track `role (N,)`."""
    return replace(clip, person=person, role=np.asarray(role, np.int8))


def turns(n: int, *, turn_s: float) -> np.ndarray:
    """(n,) int: who speaks at each 100 Hz frame, 0 then 1 then 0 …, `turn_s` seconds each."""
    return (np.arange(n) // round(turn_s * RATE_HZ)) % 2


def write_dyad_dataset(
    out: Path,
    *,
    takes: int = 20,
    seconds: float = 6.0,
    turn_s: float = 1.5,
    n_features: int = 26,
    listen_tau_s: float = 0.4,
    listen_lag_s: float = 0.3,
    seed: int = 0,
) -> Path:
    """Write `takes` two-person takes into `out` (subject "pair"), paired, with the splits
    (splits/dyadic.json among them); returns `out`."""
    rng = np.random.default_rng(seed)
    gains = rng.uniform(0.5, 2.0, n_features)
    profile = pepper.load_profile(pepper.DEFAULT_PROFILE)
    n = round(seconds * RATE_HZ)
    head, yaw = pepper.INDEX["HeadPitch"], pepper.INDEX["HeadYaw"]
    written: dict[str, list[Clip]] = {}
    for k in range(takes):
        take_id = f"pair_t{k:02d}"
        env = envelope(n, rng)
        audio = np.outer(env, gains) + rng.normal(0.0, 0.05, (n, n_features))
        speaks = motion(env, 0.25, lag_s=0.1)
        nods = motion(env, listen_tau_s, lag_s=listen_lag_s)
        who = turns(n, turn_s=turn_s)
        clips: list[Clip] = []
        for person in (0, 1):
            speaking = who == person
            angles01 = np.full((n, len(pepper.JOINTS)), 0.5)
            angles01[:, head] = np.where(speaking, 0.4 + 0.25 * speaks, 0.45 + 0.3 * nods)
            angles01[:, yaw] = np.where(speaking, 0.4 + 0.25 * speaks, 0.5)
            clip = clip_from_targets(
                _playable(angles01, profile),  # the turns switch faster than a head moves
                audio,
                clip_id=f"{take_id}__c{person:03d}",
                profile=profile,
            )
            role = np.where(speaking, SPEAKING, LISTENING)
            clips.append(with_person(clip, person=person, role=role))
        written[take_id] = pair_clips(clips)
    # generated motion holds still in pauses, which no person does: the QC is opened for it
    qc = {"max_jitter_fraction": 1.0, "max_frozen_fraction": 1.0, "outlier_z": 1e9}
    config = Config.model_validate({"qc": qc})
    subjects = dict.fromkeys(written, "pair")
    return write_dataset(Path(out), written, subjects=subjects, config=config, in_turn=False)
