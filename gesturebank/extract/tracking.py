"""Which one person per shot is the main speaker (identities: `extract.identity`; the speech
term: `extract.speech`).

Score of person k over a span S of frames (a shot, or the rest of one), from the frames F_k ⊆ S
in which k is seen; every term lies in [0, 1]:

    size_k        = median_{F_k} d_k / max_j median_{F_j} d_j     d = upper-body box diagonal, px
    centrality_k  = mean_{F_k} max(0, 1 − |c_k − image centre| / (image diagonal / 2))
    confidence_k  = mean_{F_k} mean upper-body keypoint confidence (a missing joint counts 0)
    persistence_k = |F_k| / |S|
    speech_k      = min(1, D_k / W) · max(0, max_{|ℓ| ≤ 0.3 s} mean_w ncc_w(v_k(t), e(t + ℓ)))
    total_k       = Σ_i w_i · term_i / Σ_i w_i      (w_i: the TrackingConfig *_weight fields)

c_k is the upper-body centroid. v_k is the person's head-and-hand speed (mean speed of nose and
both wrists, in shoulder widths per second, so neither the person's size in the image nor the
frame rate matters); e is the RMS envelope of the audio centred on each frame's timestamp. Both
are smoothed over SMOOTH_S, so that syllable flicker does not dominate the slower rhythm gestures
share with speech. ncc_w is their normalised cross-correlation over the frames of window w
(`speech_window_s` long, windows overlapping by half); its mean over the windows is maximised
over one lag ℓ per person and span. ℓ > 0 pairs motion with later speech: gesture strokes and
head nods lead the stressed syllable by up to a few hundred ms; the search is symmetric
because detector smoothing delays the motion and muxed audio can be a frame or two off.
Anti-correlation is not following (clipped at 0). Windows where the audio is flat (silence) or
the person is seen in less than half the frames are left out of the mean; D_k is the time the
windows kept cover, W = speech_window_s, so that less than one window of evidence (a short
shot) counts proportionally less. With no audio, or silent audio, speech_k = 0 for everybody.

Choice, per shot: candidates are the people seen in at least MIN_SHARE of the span (everybody
seen, when nobody is); the best total is the main speaker, and stays so to the end of the shot
unless absent longer than `max_lost_s`. Then the rest of the shot is chosen again (reason
"left"). A choice who first appears more than `max_lost_s` into its span is given the frames from
its arrival on (reason "arrived"); the frames before are chosen among the others, by the same
rules.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from gesturebank.config import SpeechConfig, TrackingConfig
from gesturebank.errors import DetectionError
from gesturebank.extract.bystanders import (
    bystanders_left_out,
    front_share,
    seen_from_the_front,
)
from gesturebank.extract.identity import (
    Switch,
    find_switches,
    gather,
    link,
    shot_index,
    split_at_cuts,
)
from gesturebank.extract.roles import SPEAKING, UNKNOWN, Roles
from gesturebank.extract.speech import (
    SILENCE_RMS,
    frame_step,
    head_hand_speed,
    speech_envelope,
    speech_following,
)
from gesturebank.poses import MultiPose2D, Pose2D
from gesturebank.skeletons import COCO17, get_skeleton

if TYPE_CHECKING:  # only for annotations: tracking needs no video decoder
    from gesturebank.audio.io import Audio

# What a waist-up shot shows (no knees, no ankles): a candidate's size, centre and confidence.
WAIST_UP = tuple(j for j in COCO17.joints if "knee" not in j and "ankle" not in j)
TERMS = ("size", "centrality", "confidence", "persistence", "speech")

MIN_SHARE = 0.25  # seen in less of the span: a passer-by, not a candidate
_MIN_PAIRS = 4  # fewest frames a window's correlation is computed on
_FAR = 1e12  # cost of a gated-out pair
_CUT_EPS_S = 1e-6  # a frame this close before a cut time already belongs to the new shot


@dataclass(frozen=True)
class Choice:
    """One main speaker over [start_s, end_s) of one shot.

    main_id: chosen track (-1: nobody seen there); runner_up: second-best candidate (None when
    alone); reason: why the segment starts — "shot" (a shot begins), "left" (the previous main
    speaker left), "arrived" (the chosen person came in after somebody else had the floor).
    scores: per candidate track, each of TERMS and "total", over the span the choice was made on
    (this segment and the rest of its shot).
    """

    start_s: float
    end_s: float
    shot: int
    reason: str
    main_id: int
    runner_up: int | None
    scores: dict[int, dict[str, float]] = field(default_factory=dict)

    def to_json_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out["scores"] = {str(k): dict(v) for k, v in self.scores.items()}
        return out

    @classmethod
    def from_json_dict(cls, data: Mapping[str, Any]) -> Choice:
        scores = {int(k): {t: float(x) for t, x in v.items()} for k, v in data["scores"].items()}
        runner = data["runner_up"]
        return cls(
            float(data["start_s"]),
            float(data["end_s"]),
            int(data["shot"]),
            str(data["reason"]),
            int(data["main_id"]),
            None if runner is None else int(runner),
            scores,
        )


@dataclass(frozen=True, eq=False)
class TrackReport:
    """Outcome of tracking one take.

    main_ids:      (T,) int64 chosen track of each frame (-1: no main speaker); constant within
                   a Choice — the person may still be unseen in some of its frames.
    n_people:      (T,) int64 people seen in each frame.
    choices:       the segments, in time order; they tile the take.
    switches:      suspected identity switches inside shots (`find_switches`).
    scores:        total score of every track over its whole shot.
    n_tracks:      identities after splitting at cuts.
    main_id:       main speaker of the longest segment.
    main_coverage: share of frames in which the frame's main speaker is seen.
    """

    main_ids: np.ndarray
    n_people: np.ndarray
    choices: tuple[Choice, ...]
    switches: tuple[Switch, ...]
    scores: dict[int, float]
    n_tracks: int
    main_id: int
    main_coverage: float

    @property
    def main_switches(self) -> tuple[Switch, ...]:
        """Switches involving any chosen main speaker."""
        chosen = {c.main_id for c in self.choices if c.main_id >= 0}
        return tuple(s for s in self.switches if chosen & {s.old_id, s.new_id})

    def to_json_dict(self) -> dict[str, Any]:
        """Plain JSON types only (track ids become string keys)."""
        return {
            "n_tracks": self.n_tracks,
            "main_id": self.main_id,
            "main_coverage": self.main_coverage,
            "scores": {str(k): v for k, v in self.scores.items()},
            "choices": [c.to_json_dict() for c in self.choices],
            "switches": [asdict(s) for s in self.switches],
            "main_ids": [int(v) for v in self.main_ids],
            "n_people": [int(v) for v in self.n_people],
        }

    @classmethod
    def from_json_dict(cls, data: Mapping[str, Any]) -> TrackReport:
        return cls(
            main_ids=np.asarray(data["main_ids"], dtype=np.int64),
            n_people=np.asarray(data["n_people"], dtype=np.int64),
            choices=tuple(Choice.from_json_dict(c) for c in data["choices"]),
            switches=tuple(
                Switch(float(s["timestamp"]), int(s["old_id"]), int(s["new_id"]))
                for s in data["switches"]
            ),
            scores={int(k): float(v) for k, v in data["scores"].items()},
            n_tracks=int(data["n_tracks"]),
            main_id=int(data["main_id"]),
            main_coverage=float(data["main_coverage"]),
        )


@dataclass(frozen=True)
class Tracked:
    """The main speaker's Pose2D (NaN where there is none), the (T, P) track id of every slot
    (-1 = empty), the report; with mouths measured, everybody's `roles` (UNKNOWN throughout a
    shot in which nobody's mouth follows the speech: who speaks there is not known)."""

    pose: Pose2D
    ids: np.ndarray
    report: TrackReport
    roles: Roles | None = None

    def role_of(self, track: np.ndarray) -> np.ndarray:
        """(T,) role code of the track given per frame (`report.main_ids` for the main
        speaker's); UNKNOWN without roles."""
        if self.roles is None:
            return np.full(len(track), UNKNOWN, np.int8)
        return self.roles.of(np.asarray(track))


# ------------------------------------------------------------------------------- the choice


class _Scene:
    """Per-slot measures of one take, computed once, and the scores of any span of frames."""

    def __init__(
        self,
        multi: MultiPose2D,
        ids: np.ndarray,
        config: TrackingConfig,
        envelope: np.ndarray | None,
    ) -> None:
        self.multi, self.ids, self.config, self.envelope = multi, ids, config, envelope
        self.ts = multi.timestamps
        self.end_t = float(self.ts[-1] + frame_step(self.ts)) if len(self.ts) else 0.0
        coco = get_skeleton(multi.skeleton).convert(multi.keypoints, COCO17)
        ub = coco[..., [COCO17.index[j] for j in WAIST_UP], :]  # (T, P, U, 3)
        xy = ub[..., :2]
        with warnings.catch_warnings():  # empty slots: all-NaN slices are expected
            warnings.simplefilter("ignore", RuntimeWarning)
            lo, hi = np.nanmin(xy, axis=-2), np.nanmax(xy, axis=-2)
            centre = np.nanmean(xy, axis=-2)
        w, h = multi.image_size
        off = np.linalg.norm(centre - np.array([w / 2, h / 2]), axis=-1) / (np.hypot(w, h) / 2)
        self.size = np.linalg.norm(hi - lo, axis=-1)  # (T, P) px, NaN = no upper body
        self.front = seen_from_the_front(coco[..., :2])  # (T, P) the torso turned to us
        self.central = np.clip(1.0 - off, 0.0, 1.0)
        self.conf = np.nan_to_num(ub[..., 2], nan=0.0).mean(axis=-1)
        self._speed: dict[int, tuple[int, np.ndarray]] = {}
        self._scores: dict[tuple[int, int, frozenset[int]], dict[int, dict[str, float]]] = {}

    def time_at(self, i: int) -> float:
        """Start time of frame i; the end of the take for i = T."""
        return float(self.ts[i]) if i < len(self.ts) else self.end_t

    def _speed_of(self, k: int) -> tuple[int, np.ndarray]:
        """(first frame, speed over the track's frame range) of track k, cached."""
        if k not in self._speed:
            t_idx = np.flatnonzero((self.ids == k).any(axis=1))
            lo, hi = int(t_idx[0]), int(t_idx[-1]) + 1
            part = gather(self.multi.take(np.arange(lo, hi)), self.ids[lo:hi], track_id=k)
            speed = head_hand_speed(
                keypoints=part.keypoints, timestamps=part.timestamps, skeleton=part.skeleton
            )
            self._speed[k] = (lo, speed)
        return self._speed[k]

    def _speech(self, k: int, start: int, stop: int) -> float:
        if self.envelope is None or self.config.speech_weight == 0:
            return 0.0
        first, speed = self._speed_of(k)
        span = np.full(stop - start, np.nan)
        a, b = max(start, first), min(stop, first + len(speed))
        span[a - start : b - start] = speed[a - first : b - first]
        return speech_following(
            speed=span,
            envelope=self.envelope[start:stop],
            timestamps=self.ts[start:stop],
            window_s=self.config.speech_window_s,
        )

    def scores(
        self, start: int, stop: int, exclude: frozenset[int] = frozenset()
    ) -> dict[int, dict[str, float]]:
        """TERMS and "total" of every track seen in frames [start, stop), except `exclude`."""
        key = (start, stop, exclude)
        if key not in self._scores:
            self._scores[key] = self._score(start, stop, exclude)
        return self._scores[key]

    def _score(self, start: int, stop: int, exclude: frozenset[int]) -> dict[int, dict[str, float]]:
        ids = self.ids[start:stop]
        tracks = [int(k) for k in np.unique(ids[ids >= 0]) if int(k) not in exclude]
        c = self.config
        weights = {
            "size": c.size_weight,
            "centrality": c.center_weight,
            "confidence": c.confidence_weight,
            "persistence": c.persistence_weight,
            "speech": c.speech_weight,
        }
        out: dict[int, dict[str, float]] = {}
        sizes: dict[int, float] = {}
        for k in tracks:
            mask = ids == k  # (n, P), one slot per frame at most
            seen = mask.any(axis=1)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                sizes[k] = float(np.nan_to_num(np.nanmedian(self.size[start:stop][mask])))
            out[k] = {
                "centrality": float(np.nan_to_num(np.nanmean(self.central[start:stop][mask]))),
                "confidence": float(self.conf[start:stop][mask].mean()),
                "persistence": float(seen.mean()),
                "speech": self._speech(k, start, stop),
            }
        biggest = max(sizes.values(), default=0.0)
        total_w = sum(weights.values())
        for k in tracks:
            out[k]["size"] = sizes[k] / biggest if biggest > 0 else 0.0
            terms = {t: out[k][t] for t in TERMS}
            total = sum(weights[t] * terms[t] for t in TERMS) / total_w if total_w > 0 else 0.0
            out[k] = {**terms, "total": float(total)}
        return out

    def absent_s(self, first_unseen: int, seen_again: int) -> float:
        """How long a person is unseen from frame `first_unseen` until frame `seen_again`."""
        return self.time_at(seen_again) - self.time_at(first_unseen)

    def stay_end(self, k: int, first: int, stop: int) -> int:
        """Frame after k's last sighting before an absence longer than max_lost_s (or `stop`)."""
        seen = first + np.flatnonzero((self.ids[first:stop] == k).any(axis=1))
        for g in np.flatnonzero(np.diff(seen) > 1):
            if self.absent_s(int(seen[g]) + 1, int(seen[g + 1])) > self.config.max_lost_s:
                return int(seen[g]) + 1
        last = int(seen[-1]) + 1
        if last < stop and self.absent_s(last, stop) > self.config.max_lost_s:
            return last
        return stop


def _candidates(scores: dict[int, dict[str, float]]) -> dict[int, dict[str, float]]:
    keep = {k: v for k, v in scores.items() if v["persistence"] >= MIN_SHARE}
    return keep or scores


def _choose(
    scene: _Scene, start: int, stop: int, *, shot: int, reason: str, exclude: frozenset[int]
) -> list[tuple[int, int, Choice]]:
    """(first frame, end frame, Choice) of the segments tiling frames [start, stop) of a shot."""
    out: list[tuple[int, int, Choice]] = []
    while start < stop:
        cands = _candidates(scene.scores(start, stop, exclude))
        if not cands:
            out.append((start, stop, _segment(scene, start, stop, shot, reason, -1, None, {})))
            break
        ranked = sorted(cands, key=lambda k: (-cands[k]["total"], -cands[k]["persistence"], k))
        main, runner = ranked[0], (ranked[1] if len(ranked) > 1 else None)
        first = start + int(np.flatnonzero((scene.ids[start:stop] == main).any(axis=1))[0])
        if scene.absent_s(start, first) > scene.config.max_lost_s:
            # The choice comes in late: whoever is best among the others has the floor until then.
            out += _choose(scene, start, first, shot=shot, reason=reason, exclude=exclude | {main})
            start, reason = first, "arrived"
        end = scene.stay_end(main, first, stop)
        out.append((start, end, _segment(scene, start, end, shot, reason, main, runner, cands)))
        start, reason = end, "left"
    return out


def _segment(
    scene: _Scene,
    start: int,
    end: int,
    shot: int,
    reason: str,
    main: int,
    runner: int | None,
    scores: dict[int, dict[str, float]],
) -> Choice:
    return Choice(scene.time_at(start), scene.time_at(end), shot, reason, main, runner, scores)


# A candidate seen facing the camera in at least this share of its frames faces it (Sports2D
# demo: the man on the box 49 %, the woman walking past 3 %; Pose2Sim cam02: 60 % and 0 %).
FACING_SHARE = 0.25


def _runs(label: np.ndarray) -> list[tuple[int, int, int]]:
    """(start, stop, value) of the runs of equal values of `label`."""
    edges = np.flatnonzero(np.diff(label)) + 1
    starts = np.r_[0, edges]
    stops = np.r_[edges, len(label)]
    return [(int(a), int(b), int(label[a])) for a, b in zip(starts, stops, strict=True)]


def turns(
    *, speaking: np.ndarray, rank: np.ndarray, timestamps: np.ndarray, min_turn_s: float
) -> np.ndarray:
    """(n,) column of the speaker at each frame of one shot, from `speaking (n, S)` (who
    speaks at each frame) and `rank (S,)` (lower first, for frames where several speak).

    A speaker takes the floor where they start speaking in at least half the frames of the
    `min_turn_s` from there (a shorter turn, or a blip of a listener's mouth, changes nothing)
    and keeps it through pauses until another takes it; the first one has it from the shot's
    start. -1 when nobody speaks."""
    n = len(speaking)
    raw = np.full(n, -1, np.int64)
    for c in np.argsort(rank, kind="stable")[::-1]:  # the best-ranked speaker written last wins
        raw[speaking[:, c]] = c
    label = np.full(n, -1, np.int64)
    if not (raw >= 0).any():
        return label
    horizon = np.searchsorted(timestamps, timestamps + min_turn_s, side="left")
    counts = np.vstack([np.zeros((1, speaking.shape[1]), np.int64), np.cumsum(speaking, 0)])
    current = -1
    for i in range(n):
        c = int(raw[i])
        if c >= 0 and c != current:
            end = max(int(horizon[i]), i + 1)
            if 2 * (counts[end, c] - counts[i, c]) >= end - i:
                current = c
        label[i] = current
    if not (label >= 0).any():  # nobody speaks long at a stretch: the first who speaks
        return np.full(n, raw[np.flatnonzero(raw >= 0)[0]], np.int64)
    label[label < 0] = label[np.flatnonzero(label >= 0)[0]]  # the floor from the shot's start
    return label


def _by_roles(
    scene: _Scene,
    roles: Roles,
    start: int,
    stop: int,
    *,
    shot: int,
    speech: SpeechConfig | None,
) -> tuple[list[tuple[int, int, Choice]], bool]:
    """The segments of one shot chosen by who speaks, and whether anybody's mouth followed
    the speech there.

    A track speaks in the shot when its role is "speaking" for at least min_speaking_s; then
    the speaker at each frame is whoever of those speaks (ties: the best total score), held
    through pauses (`turns`). Nobody speaks: people with their back to us when others face us,
    and bystanders (much smaller than the biggest who faces us, or at the edge of the picture:
    `bystanders_left_out`) are left out; alone (no two of the rest in one frame), the dominant
    one is chosen (role unknown); among several at once, the one whose face is seen facing the
    camera (FACING_SHARE of its frames), and with none or several of them nobody (main_id -1,
    reason "nobody")."""
    min_s = (speech or SpeechConfig()).min_speaking_s
    ts = scene.ts[start:stop]
    step = frame_step(scene.ts)
    scores = scene.scores(start, stop)
    role = roles.role[start:stop]
    spoken = {
        int(k): float((role[:, m] == SPEAKING).sum()) * step
        for m, k in enumerate(roles.track_ids)
        if int(k) in scores
    }
    speakers = [k for k, sec in spoken.items() if sec >= max(min_s, step)]
    if speakers:
        cols = [roles.column(k) for k in speakers]
        speaking = np.stack([role[:, c] == SPEAKING for c in cols], axis=1)
        rank = np.array([-scores[k]["total"] for k in speakers])
        label = turns(speaking=speaking, rank=rank, timestamps=ts, min_turn_s=min_s)
        out = []
        for a, b, c in _runs(label):
            main = speakers[c] if c >= 0 else -1
            others = sorted((k for k in speakers if k != main), key=lambda k: -scores[k]["total"])
            runner = others[0] if others else None
            out.append(
                (
                    start + a,
                    start + b,
                    _segment(scene, start + a, start + b, shot, "speaks", main, runner, scores),
                )
            )
        return out, True
    cands = _candidates(scores)
    # small, far or edge-of-frame people are bystanders: they never veto (issue 41)
    front = front_share(scene.ids[start:stop], scene.front[start:stop], cands=cands)
    rivals = bystanders_left_out(cands, front, config=scene.config)
    together = [(scene.ids[start:stop] == k).any(axis=1) for k in rivals]
    # one person is alone even when the tracker broke them into several tracks one after another
    if len(rivals) <= 1 or int(np.sum(together, axis=0).max()) <= 1:
        exclude = frozenset(cands) - frozenset(rivals)
        return _choose(scene, start, stop, shot=shot, reason="shot", exclude=exclude), False
    facing = []
    for k in rivals:
        m = roles.column(k)
        seen = (scene.ids[start:stop] == k).any(axis=1)
        if (
            m is not None
            and seen.any()
            and roles.facing[start:stop][seen, m].mean() >= FACING_SHARE
        ):
            facing.append(k)
    if len(facing) == 1:
        rest = frozenset(int(k) for k in np.unique(scene.ids[start:stop]) if k >= 0) - {facing[0]}
        return _choose(scene, start, stop, shot=shot, reason="shot", exclude=rest), False
    return [(start, stop, _segment(scene, start, stop, shot, "nobody", -1, None, cands))], False


def track_ids(multi: MultiPose2D, config: TrackingConfig, *, cuts: np.ndarray | None) -> np.ndarray:
    """(T, P) track id of every slot (-1 = empty), one set of ids per shot: what
    `main_speaker` chooses among (give it back as its `ids`)."""
    return _identities(multi, config, shot_index(timestamps=multi.timestamps, cuts=cuts))


def _identities(multi: MultiPose2D, config: TrackingConfig, shot: np.ndarray) -> np.ndarray:
    """(T, P) ids, one set per shot: the detector's, else `link` run on each shot alone."""
    present = multi.present
    if multi.ids is not None:
        raw = np.where(present, multi.ids, -1)
    else:
        raw = np.full(present.shape, -1, np.int64)
        for s in np.unique(shot):
            frames = np.flatnonzero(shot == s)
            linked = link(multi.take(frames), config=config)
            raw[frames] = np.where(linked >= 0, linked, -1)
    return split_at_cuts(ids=raw, shot=shot)


def main_speaker(
    multi: MultiPose2D,
    config: TrackingConfig | None = None,
    *,
    cuts: np.ndarray | None = None,
    audio: Audio | None = None,
    source: str = "take",
    ids: np.ndarray | None = None,
    roles: Roles | None = None,
    speech: SpeechConfig | None = None,
    keep: int | None = None,
) -> Tracked:
    """One main speaker per shot (module docstring): their Pose2D over the take, ids, report.

    multi: everybody, (T, P, K, 3), with `ids` when the detector tracks people; cuts: (S,)
    seconds, the first frame of each new shot (None: one shot); audio: the take's audio for the
    speech term (None: speech term 0). ids: `track_ids(multi, config, cuts=cuts)` when already
    made. roles: everybody's roles (`extract.roles`) on those ids: then the main speaker is the
    one who speaks (`_by_roles`, with speech.min_speaking_s). keep: a track id named by the
    user (`extract.people_file`): the main speaker wherever seen. Raises DetectionError (naming
    `source`) when nobody is found in any frame.
    """
    config = config or TrackingConfig()
    shot = shot_index(timestamps=multi.timestamps, cuts=cuts)
    ids = _identities(multi, config, shot) if ids is None else ids
    if not (ids >= 0).any():
        raise DetectionError(f"{source}: no person detected in any of {len(multi)} frames")
    envelope = None
    if audio is not None and config.speech_weight > 0:
        env = speech_envelope(audio=audio, timestamps=multi.timestamps)
        if np.isfinite(env).any() and float(np.nanmax(env)) >= SILENCE_RMS:
            envelope = env
    scene = _Scene(multi, ids, config, envelope)

    segments: list[tuple[int, int, Choice]] = []
    scores: dict[int, float] = {}
    switches: list[Switch] = []
    role = None if roles is None else roles.role.copy()
    for s in np.unique(shot):
        frames = np.flatnonzero(shot == s)
        a, b = int(frames[0]), int(frames[-1]) + 1
        scores.update({k: v["total"] for k, v in scene.scores(a, b).items()})
        if keep is not None:
            segments.append((a, b, _segment(scene, a, b, int(s), "named", keep, None, {})))
        elif roles is not None:
            shot_segments, spoke = _by_roles(scene, roles, a, b, shot=int(s), speech=speech)
            segments += shot_segments
            if not spoke and role is not None:  # who speaks here is not known
                role[a:b] = UNKNOWN
        else:
            segments += _choose(scene, a, b, shot=int(s), reason="shot", exclude=frozenset())
        switches += find_switches(multi.timestamps[a:b], ids[a:b], window_s=config.switch_window_s)

    main_ids = np.full(len(multi), -1, np.int64)
    for a, b, choice in segments:
        main_ids[a:b] = choice.main_id
    pose = gather(multi, ids, track_id=main_ids)
    spoken = [c for _, _, c in segments if c.main_id >= 0]
    longest = (
        max(spoken, key=lambda c: c.end_s - c.start_s)
        if spoken
        else Choice(0.0, 0.0, 0, "nobody", -1, None)
    )
    report = TrackReport(
        main_ids=main_ids,
        n_people=(ids >= 0).sum(axis=1).astype(np.int64),
        choices=tuple(c for _, _, c in segments),
        switches=tuple(switches),
        scores=scores,
        n_tracks=len(scores),
        main_id=longest.main_id,
        main_coverage=float(np.isfinite(pose.keypoints[..., 0]).any(axis=1).mean()),
    )
    out_roles = None if roles is None or role is None else roles.with_role(role)
    return Tracked(pose, ids, report, out_roles)
