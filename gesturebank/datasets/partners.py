"""Partners: the clips of two people of one take that overlap in time (issue 32, seed 004's
speaker and listener).

With `build.people = "all"` a take may give clips of several people. A clip's partner is the
clip of another person of the same take that overlaps it longest in time (ties: the smaller clip
id); `partner_speaking` is that partner's role track ("speaking") sampled at the clip's own
frame times, False where the partner's clip does not cover them. Pairing is per clip, so it need
not be symmetric: a clip overlapping two clips of its partner is the partner of both, and has
the longer one as its own.

`check_partners` is the invariant, checked where a take's clips are written (`store.write_take`):
a partner is a clip of the same take, of another person, that overlaps the clip in time.

The person and role of a clip are read in one place, `voice_of`, so the pairing does not depend
on how a clip stores them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from gesturebank.clip import Clip
from gesturebank.errors import InputError

# The code of "speaking" in `clip.ROLES` ("unknown", "speaking", "listening"): codes 0, 1, 2.
SPEAKING = 1
LISTENING = 2


@dataclass(frozen=True)
class Voice:
    """What pairing needs of one clip: whose it is, when it is (source seconds of its 100 Hz
    frames: start_s + times), and when that person speaks (bool per frame)."""

    clip_id: str
    person: int
    times_s: np.ndarray
    speaking: np.ndarray

    @property
    def span(self) -> tuple[float, float]:
        """[first frame, one hop past the last frame) in source seconds."""
        hop = float(np.median(np.diff(self.times_s))) if len(self.times_s) > 1 else 0.01
        return float(self.times_s[0]), float(self.times_s[-1]) + hop


def person_of(clip: Clip) -> int:
    """The clip's person id within its take (0 when clips carry no person: one per take)."""
    return int(getattr(clip, "person", 0))


def role_of(clip: Clip) -> np.ndarray:
    """The clip's role track `(N,)` int8 (`clip.ROLES` codes; all "unknown" when clips carry
    none)."""
    role = getattr(clip, "role", None)
    return np.zeros(len(clip.times), np.int8) if role is None else np.asarray(role, np.int8)


def role_in(arrays: Mapping[str, np.ndarray], n: int) -> np.ndarray:
    """The role track `(n,)` int8 of a clip's arrays as read from its file (all "unknown" when
    the file has none)."""
    role = arrays.get("role")
    return np.zeros(n, np.int8) if role is None else np.asarray(role, np.int8)


def voice_of(clip: Clip) -> Voice:
    return Voice(
        clip_id=clip.clip_id,
        person=person_of(clip),
        times_s=clip.start_s + np.asarray(clip.times, np.float64),
        speaking=role_of(clip) == SPEAKING,
    )


def overlap_s(a: Voice, b: Voice) -> float:
    """Seconds in which the spans of `a` and `b` overlap (0 when they do not)."""
    (a0, a1), (b0, b1) = a.span, b.span
    return max(0.0, min(a1, b1) - max(a0, b0))


def partner_of(voice: Voice, others: Sequence[Voice]) -> Voice | None:
    """The clip of another person overlapping `voice` longest (ties: smallest clip id)."""
    best: tuple[float, str] | None = None
    found = None
    for other in others:
        shared = overlap_s(voice, other)
        if other.person == voice.person or shared <= 0:
            continue
        key = (-shared, other.clip_id)
        if best is None or key < best:
            best, found = key, other
    return found


def speaking_at(partner: Voice, times_s: np.ndarray) -> np.ndarray:
    """(N,) bool: the partner speaks at each of `times_s` (source seconds): its frame nearest to
    each time (its frames are uniform); False outside its clip."""
    t = np.asarray(times_s, np.float64)
    n = len(partner.times_s)
    if n == 0:
        return np.zeros(len(t), bool)
    hop = float(np.median(np.diff(partner.times_s))) if n > 1 else 0.01
    k = np.rint((t - partner.times_s[0]) / hop).astype(np.int64)
    inside = (k >= 0) & (k < n)
    out = np.zeros(len(t), bool)
    out[inside] = partner.speaking[k[inside]]
    return out


def pair_voices(voices: Sequence[Voice]) -> dict[str, tuple[str, np.ndarray]]:
    """clip id → (its partner's clip id, partner_speaking (N,) bool) for every voice that has a
    partner."""
    out = {}
    for voice in voices:
        partner = partner_of(voice, voices)
        if partner is not None:
            out[voice.clip_id] = (partner.clip_id, speaking_at(partner, voice.times_s))
    return out


def pair_clips(clips: Sequence[Clip]) -> list[Clip]:
    """The take's clips (in their order) with `partner_clip_id` and `partner_speaking` set; a
    clip without partner gets "" and all False."""
    pairs = pair_voices([voice_of(c) for c in clips])
    out = []
    for clip in clips:
        partner_id, speaking = pairs.get(clip.clip_id, ("", np.zeros(len(clip.times), bool)))
        out.append(replace(clip, partner_clip_id=partner_id, partner_speaking=speaking))
    return out


def check_partners(clips: Sequence[Clip], *, take_id: str) -> None:
    """InputError (one line) unless every partner is a clip of `clips` (the same take), of
    another person, overlapping the clip in time."""
    voices = {c.clip_id: voice_of(c) for c in clips}
    for clip in clips:
        if not clip.partner_clip_id:
            continue
        partner = voices.get(clip.partner_clip_id)
        if partner is None:
            raise InputError(
                f"{take_id}: clip {clip.clip_id}'s partner {clip.partner_clip_id} is not a clip "
                "of the same take"
            )
        own = voices[clip.clip_id]
        if partner.person == own.person:
            raise InputError(
                f"{take_id}: clip {clip.clip_id}'s partner {partner.clip_id} is the same person "
                f"({own.person})"
            )
        if overlap_s(own, partner) <= 0:
            raise InputError(
                f"{take_id}: clip {clip.clip_id} and its partner {partner.clip_id} do not overlap "
                "in time"
            )
