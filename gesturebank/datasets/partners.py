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

"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from gesturebank.clip import ROLES, Clip
from gesturebank.errors import InputError

SPEAKING = ROLES.index("speaking")
LISTENING = ROLES.index("listening")


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


def voice_of(clip: Clip) -> Voice:
    return Voice(
        clip_id=clip.clip_id,
        person=int(clip.person),
        times_s=clip.start_s + np.asarray(clip.times, np.float64),
        speaking=np.asarray(clip.role) == SPEAKING,
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
