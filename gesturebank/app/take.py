"""One take through the whole pipeline into clips (docs/architecture.md "Data flow").

extract (decode, detect everybody + shot cuts — cached —, the main speaker per shot, audio) →
repair the main speaker's keypoints → speech activity over the take (`audio.vad`) → cut the
take into clips (shots, speaker changes, absences and unusable stretches, audio, silences over
`speech.max_silence_s`, `clips.min_s`) → per clip: lift, Pepper angles (masked where a
limb was not seen), the 100 Hz processing, audio features on the same clock, QC metrics and the
absolute verdict. The dataset-relative verdicts come later, over every clip (`datasets.refresh`).
Raises on failure; the builder turns that into a `failed` record.
"""

from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from gesturebank.app.clip import build_clip, covering, take_activity
from gesturebank.app.views import TakeView, mocap_view, multi_view, single_views
from gesturebank.audio.vad import silences
from gesturebank.clip import Clip
from gesturebank.config import Config
from gesturebank.datasets.cut import Span, cut_clips, frame_ends, trimmed_share
from gesturebank.datasets.digest import content_digest, measure_digest
from gesturebank.datasets.judging import judged_records
from gesturebank.datasets.partners import pair_clips
from gesturebank.datasets.records import ClipRecord, TakeRecord
from gesturebank.datasets.takes import Take
from gesturebank.qc.usable import usable_frames
from gesturebank.robot import pepper

if TYPE_CHECKING:
    from gesturebank.extract.cache import DetectionCache

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BuiltTake:
    """A take's record, its clips and its preview strip (JPEG bytes)."""

    record: TakeRecord
    clips: tuple[Clip, ...]
    preview: bytes | None
    detect_s: float
    cached: bool | None = None  # its detections came from the cache (None: not cached)


def check_names(config: Config) -> None:
    """The detector, lifter and robot profile a build uses by name, checked before any take
    starts (a typo is one usage error, not a failure of every take); imports no model."""
    from gesturebank.extract.detectors import DETECTORS
    from gesturebank.lift import LIFTERS

    DETECTORS.check(config.detector.name)
    LIFTERS.check(config.lifter.name)
    pepper.load_profile(config.robot.profile)


NOBODY_SPEAKS = "nobody speaks: several people and no mouth follows the speech"


def _why_dropped(span: Span, view: TakeView) -> str:
    """A span's reason; "main speaker absent" where people were there but nobody was made the
    speaker (dubbed speech over several people) says so."""
    a, b = span.start, max(span.stop, span.start + 1)
    nobody = (view.speaker[a:b] < 0).all() and view.n_people[a:b].max(initial=0) >= 2
    return NOBODY_SPEAKS if span.reason == "main speaker absent" and nobody else span.reason


def _preview_jpeg(frames: tuple[tuple[float, np.ndarray], ...]) -> bytes | None:
    """The preview frames side by side as one JPEG (the dashboard draws skeletons over it)."""
    import cv2

    if not frames:
        return None
    height = min(f.shape[0] for _, f in frames)
    strip = np.hstack([f[:height] for _, f in frames])
    ok, jpg = cv2.imencode(
        ".jpg", cv2.cvtColor(strip, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 80]
    )
    return jpg.tobytes() if ok else None


def build_take(
    take: Take, source: str, *, config: Config, chunks: DetectionCache | None = None
) -> BuiltTake:
    """Every clip of one take, its record (clips, dropped spans, QC metrics and absolute
    verdicts) and its preview; raises a GesturebankError when the take cannot be built.
    chunks: where videos longer than build.chunk_s find their chunks' detections (None: every
    video is detected in one pass)."""
    from gesturebank.audio.features import features

    if take.mocap:
        views = [mocap_view(take, config)]
    elif take.multi_camera:  # people are not matched across cameras: the main speaker only
        views = [multi_view(take, config=config, chunks=chunks)]
    else:
        views = single_views(take, config=config, chunks=chunks)
    view = views[0]  # the audio, clock, detector and preview are the take's, the same in each
    profile = pepper.load_profile(config.robot.profile)
    ts = view.pose2d.timestamps
    audio_end = view.audio.start_s + len(view.audio.signal) / view.audio.sample_rate
    audio_span = (float(view.audio.start_s), float(audio_end))
    # missing audio is silence (issue 32): features over digital silence where the track is not
    heard = covering(view.audio, ts, margin_s=config.audio.winlen_s)
    feats = features(heard.signal, heard.sample_rate, config=config.audio)
    activity = take_activity(view.audio, ts, config=config)
    trimmed = trimmed_share(ts, audio_span)  # judged on every clip (qc.max_trimmed_fraction)
    if trimmed > config.qc.max_trimmed_fraction:
        log.warning(
            "%s: audio and video overlap for %.0f%% of the video; trimming to their common span "
            "drops %.0f%% of it (more than qc.max_trimmed_fraction %.0f%%)",
            *(take.audio or take.video, 100 * (1 - trimmed), 100 * trimmed),
            100 * config.qc.max_trimmed_fraction,
        )
    measured = measure_digest(qc=config.qc, profile=config.robot.profile)
    clips: list[Clip] = []
    rows: list[ClipRecord] = []
    n_spans = 0
    present = np.zeros(len(ts), bool)
    for person_view in views:
        seen = np.isfinite(person_view.pose2d.keypoints[..., 0]).any(axis=1)
        present |= seen
        cutting = cut_clips(
            timestamps=ts,
            cuts=person_view.cuts,
            speaker=person_view.speaker,
            present=seen,
            usable=usable_frames(person_view.valid),
            audio_span=audio_span,
            silences=silences(activity, max_silence_s=config.speech.max_silence_s).cut,
            config=config.clips,
        )
        for span in cutting.clips:
            whole = build_clip(
                person_view,
                span,
                clip_id=f"{take.take_id}__whole",
                take_id=take.take_id,
                feats=feats,
                feats_start_s=heard.start_s,
                activity=activity,
                config=config,
                profile=profile,
            )
            # judged, and cut around the stretches that fail (issue 41); trimmed_fraction is of
            # the whole take, so each of its clips carries it
            kept, judged = judged_records(
                whole,
                qc=config.qc,
                min_s=config.clips.min_s,
                profile=profile,
                measured=measured,
                trimmed=trimmed,
                clip_ids=(f"{take.take_id}__c{len(clips) + k:03d}" for k in itertools.count()),
                span_ids=(f"{take.take_id}__s{n_spans + k:03d}" for k in itertools.count()),
            )
            clips += kept
            rows += judged
            n_spans += sum(r.kind == "span" for r in judged)
        for span in cutting.dropped:
            rows.append(
                ClipRecord(
                    f"{take.take_id}__s{n_spans:03d}",
                    "span",
                    span.start_s,
                    span.end_s,
                    "rejected",
                    (_why_dropped(span, person_view),),
                    person=-1,
                )
            )
            n_spans += 1
    clips = pair_clips(clips)  # clips of two people at once (build.people = "all") are partners
    partners = {c.clip_id: c.partner_clip_id for c in clips}
    rows = [replace(r, partner_clip_id=partners.get(r.clip_id, "")) for r in rows]
    rows.sort(key=lambda r: r.start_s)
    ends = frame_ends(ts)
    audio_stats = _audio_sums([c.audio for c in clips], feats.shape[1])
    record = TakeRecord(
        take_id=take.take_id,
        subject=take.subject,
        source=source,
        config_digest=content_digest(config),
        detector=view.detector,
        lifter=view.lifter,
        video_fps=view.video_fps,
        seconds=float(ends[-1] - ts[0]),
        visible_s=float(np.sum((ends - ts)[present])),
        clips=tuple(rows),
        tracking={**view.tracking, "repairs": view.repairs},
        audio=audio_stats,
        preview_times=tuple(t for t, _ in view.preview),
        traits=take.traits,
    )
    preview = _preview_jpeg(view.preview)
    return BuiltTake(record, tuple(clips), preview, view.detect_s, view.cached)


def _audio_sums(feats: list[np.ndarray], dim: int) -> dict[str, object]:
    """Frame count and per-feature sums of every clip's features: the z-norm stats of a subject
    combine these over its takes without loading any clip again."""
    stacked = np.concatenate(feats).astype(np.float64) if feats else np.zeros((0, dim))
    return {
        "n": len(stacked),
        "sum": stacked.sum(axis=0).tolist(),
        "sumsq": np.square(stacked).sum(axis=0).tolist(),
    }
