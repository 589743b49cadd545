"""Where a take is cut into clips (docs/architecture.md "Data flow": cut).

A clip is a run of video frames that lies in one shot, follows one main speaker, has a usable
pose at its first and last frame, contains no unusable stretch longer than `clips.max_gap_s`
(shorter ones stay inside, masked) nor a stretch without video frames (a damaged part of the
file, `MISSING_INTERVALS`), holds no silence longer than `speech.max_silence_s` (the silences
given, issue 32: shorter ones stay inside, marked in the clip's `speech`; time without audio, a
late or short track, counts as silence and is judged by the same rule), and lasts at least
`clips.min_s`; clips longer
than `clips.max_s` are split into equal parts. Every other stretch of the take becomes a dropped
span with its reason, so the spans and clips together cover the whole take.

Pure functions over per-frame arrays; times are the video's own timestamps (VFR-safe).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gesturebank.config import ClipsConfig


@dataclass(frozen=True)
class Span:
    """Frames [start, stop) of the take, from start_s to end_s (seconds, the next frame's time
    or the last frame's end); `reason` is empty for a clip."""

    start: int
    stop: int
    start_s: float
    end_s: float
    reason: str = ""

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


@dataclass(frozen=True)
class Cutting:
    clips: tuple[Span, ...]
    dropped: tuple[Span, ...]


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) of each run of True."""
    edges = np.diff(np.concatenate([[0], np.asarray(mask, np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


# Frames more than this many times their neighbouring intervals apart have frames missing
# between them (a damaged stretch of the video that did not decode, or a recording that
# stopped); a variable frame rate changes its interval without such a gap. The frame before the
# gap lasts as long as the interval before it, and the gap is no frame's.
MISSING_INTERVALS = 4.0


def frame_ends(timestamps: np.ndarray) -> np.ndarray:
    """(T,) when each frame ends: the next frame's time; the last lasts one median interval,
    and the last before frames go missing (`MISSING_INTERVALS`) its own previous interval."""
    t = np.asarray(timestamps, dtype=np.float64)
    if len(t) < 2:
        return t + 0.0
    step = np.diff(t)
    dt = float(np.median(step))
    before = np.concatenate([[step[0]], step[:-1]])  # the interval before each step
    after = np.concatenate([step[1:], [step[-1]]])  # and after it
    gap = step > MISSING_INTERVALS * np.maximum(before, after)
    nxt = np.where(gap, t[:-1] + before, t[1:])
    return np.append(nxt, t[-1] + dt)


def missing_frames(timestamps: np.ndarray, longer_than_s: float) -> list[tuple[int, float, float]]:
    """Stretches without video frames (see `MISSING_INTERVALS`) longer than `longer_than_s`:
    (index of the first frame after, start s, end s) each."""
    t = np.asarray(timestamps, dtype=np.float64)
    ends = frame_ends(t)
    gone = np.flatnonzero(t[1:] - ends[:-1] > max(longer_than_s, 0.0))
    return [(int(i) + 1, float(ends[i]), float(t[i + 1])) for i in gone]


def has_audio(timestamps: np.ndarray, audio_span: tuple[float, float]) -> np.ndarray:
    """(T,) bool: the frames at `timestamps` (s) inside `audio_span` (first, last time)."""
    t = np.asarray(timestamps, dtype=np.float64)
    return np.asarray((t >= audio_span[0]) & (t <= audio_span[1]))


SILENCE = "no speech: silence longer than speech.max_silence_s"


def in_silence(timestamps: np.ndarray, silences: Sequence[tuple[float, float]]) -> np.ndarray:
    """(T,) bool: the frames at `timestamps` (s) inside one of `silences` ([start, end) s)."""
    t = np.asarray(timestamps, dtype=np.float64)
    out = np.zeros(len(t), dtype=bool)
    for start, end in silences:
        out |= (t >= start) & (t < end)
    return out


def trimmed_share(timestamps: np.ndarray, audio_span: tuple[float, float]) -> float:
    """Share of the video's time (`timestamps` (T,) s, each frame until the next) without audio:
    what trimming audio and video to their common span drops of the video."""
    ends = frame_ends(timestamps)
    lasts = ends - np.asarray(timestamps, dtype=np.float64)
    total = float(lasts.sum())
    return float(lasts[~has_audio(timestamps, audio_span)].sum()) / total if total > 0 else 0.0


def cut_clips(
    *,
    timestamps: np.ndarray,
    cuts: np.ndarray,
    speaker: np.ndarray,
    present: np.ndarray,
    usable: np.ndarray,
    audio_span: tuple[float, float],
    silences: Sequence[tuple[float, float]] = (),
    config: ClipsConfig,
) -> Cutting:
    """Clips and dropped spans of one take.

    timestamps (T,) s; cuts (S,) s: first frame of each new shot; speaker (T,) int: the main
    speaker's track id per frame (−1 none; a change of speaker ends a clip); present (T,) bool:
    the main speaker was detected; usable (T,) bool: the repaired pose is good enough to keep
    (frames that are not stay inside a clip, masked, when the stretch is short); audio_span:
    (first, last) time of the audio track; silences: (start, end) s of each silence that cuts,
    missing audio included (frames inside one give no clip, reason `SILENCE`, or "no audio"
    where the track has none). Frames without audio outside them stay inside a clip, silent.
    """
    cutter = _Cutter(np.asarray(timestamps, dtype=np.float64), np.asarray(present, bool), config)
    t = cutter.t
    speaker = np.asarray(speaker)
    usable = np.asarray(usable, bool) & cutter.present & (speaker >= 0)
    audio = has_audio(t, audio_span)
    silent = in_silence(t, silences)
    # Pieces no clip crosses: shots and changes of the main speaker.
    starts = np.searchsorted(t, np.asarray(cuts, dtype=np.float64), side="left")
    boundary = np.zeros(len(t), dtype=bool)
    boundary[starts[(starts > 0) & (starts < len(t))]] = True
    boundary[1:] |= speaker[1:] != speaker[:-1]
    # Stretches without frames (a damaged video): each side is judged on its own.
    for i, start_s, end_s in missing_frames(t, 0.0):
        boundary[i] = True
        cutter.dropped.append(
            Span(
                i,
                i,
                start_s,
                end_s,
                f"no video frames from {start_s:.2f} to {end_s:.2f} s (damaged or missing)",
            )
        )
    edges = [0, *np.flatnonzero(boundary).tolist(), len(t)]
    for a0, b0 in itertools.pairwise(edges):
        for a, b in _runs(~audio[a0:b0] & silent[a0:b0]):
            cutter.drop(a0 + a, a0 + b, "no audio")
        for a, b in _runs(audio[a0:b0] & silent[a0:b0]):
            cutter.drop(a0 + a, a0 + b, SILENCE)
        for a, b in _runs(~silent[a0:b0]):
            cutter.piece(a0 + a, a0 + b, usable)
    return Cutting(
        tuple(sorted(cutter.clips, key=lambda s: s.start)),
        tuple(sorted(cutter.dropped, key=lambda s: s.start)),
    )


class _Cutter:
    """Collects the clips and dropped spans of one take."""

    def __init__(self, t: np.ndarray, present: np.ndarray, config: ClipsConfig) -> None:
        self.t, self.ends, self.present, self.config = t, frame_ends(t), present, config
        self.clips: list[Span] = []
        self.dropped: list[Span] = []

    def span(self, a: int, b: int, reason: str = "") -> Span:
        return Span(int(a), int(b), float(self.t[a]), float(self.ends[b - 1]), reason)

    def drop(self, a: int, b: int, reason: str = "") -> None:
        """[a, b) gives no clip; without a reason it was unusable (absent or unseen)."""
        if b > a:
            if not reason:
                reason = (
                    "no usable pose (torso unseen, or head and both arms unseen)"
                    if self.present[a:b].any()
                    else "main speaker absent"
                )
            self.dropped.append(self.span(a, b, reason))

    def piece(self, a0: int, b0: int, usable: np.ndarray) -> None:
        """Cut [a0, b0) at unusable stretches longer than max_gap_s; keep the parts ≥ min_s."""
        c = self.config
        runs = [[a0 + a, a0 + b] for a, b in _runs(usable[a0:b0])]
        merged: list[list[int]] = []
        for a, b in runs:  # usable runs separated by a short gap make one clip
            if merged and self.t[a] - self.ends[merged[-1][1] - 1] <= c.max_gap_s:
                merged[-1][1] = b
            else:
                merged.append([a, b])
        last = a0
        for a, b in merged:
            self.drop(last, a)
            last = b
            whole = self.span(a, b)
            if whole.duration_s < c.min_s:
                self.drop(a, b, f"too short: {whole.duration_s:.2f} s < {c.min_s:g} s")
                continue
            parts = 1 if c.max_s is None else math.ceil(whole.duration_s / c.max_s - 1e-9)
            inner = np.searchsorted(self.t, np.linspace(whole.start_s, whole.end_s, parts + 1))
            edges = [a, *inner[1:-1].tolist(), b]
            self.clips += [self.span(p, q) for p, q in itertools.pairwise(edges)]
        self.drop(last, b0)
