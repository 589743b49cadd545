"""Who speaks when: every tracked person's mouth against the speech, as a role per frame.

For each track, on at most `speech.mouth_rate_hz` frames a second (decoded again, cheaply: only
the kept frames are converted to RGB), the face crop of `extract.mouth` is taken where the
person faces the camera with a face of at least `min_face_px`, and the face landmark model gives
the mouth opening. Its speaking score (`mouth.speaking_score`) against the speech envelope on
those frames gives the role of the person at each measured frame:

    speaking   score ≥ speaking_threshold and speech heard (Silero VAD) within
               speaking_max_lag_s before the frame (the mouth lags the sound)
    listening  the mouth measured and not speaking
    unknown    the mouth not measured (face unseen, turned away, too small)

Each video frame takes the role of the nearest measured frame (sampled frames at most 1 / 15 s
apart). `facing` (the face's nose and eyes turned to the camera, whatever its size) is kept for
every frame: the main-speaker choice uses it where no mouth follows the speech.

The same model runs give the head's pose (`extract.head_pose`, issue 40): each face is measured
once per sampled frame, for its mouth and its head. The head also takes faces turned further
and smaller than the mouth does (`head_limits`); their meshes give no mouth opening.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gesturebank.audio.vad import RATE_HZ, speech_activity
from gesturebank.config import SpeechConfig, VideoConfig
from gesturebank.extract.detectors.blazepose import Roi
from gesturebank.extract.head_pose import (
    MIN_HEAD_PRESENCE,
    HeadPoses,
    fit_head,
    head_box,
    mesh_roi,
    spread_heads,
)
from gesturebank.extract.mouth import MIN_FACE_PRESENCE, FaceLandmarker, face_box, speaking_score
from gesturebank.extract.speech import speech_envelope
from gesturebank.poses import MultiPose2D

if TYPE_CHECKING:
    from pathlib import Path

    from gesturebank.audio.io import Audio

# Codes of the role track; gesturebank.clip.ROLES names them in this order (a test keeps them so).
UNKNOWN, SPEAKING, LISTENING = 0, 1, 2
ENVELOPE_SMOOTH_S = 0.1  # syllables, not the slower gesture rhythm of `extract.speech`
_MATCH_S = 1e-3  # a re-decoded frame is the detected frame whose timestamp lies this close


@dataclass(frozen=True)
class Roles:
    """Per tracked person, on the take's T video frames.

    track_ids (M,) int64; score (T, M) float32 speaking score (NaN where not measured or
    nothing to follow); role (T, M) int8 codes UNKNOWN/SPEAKING/LISTENING; facing (T, M) bool:
    seen facing the camera; measured (T, M) bool: the mouth was measured on that very frame.
    """

    track_ids: np.ndarray
    score: np.ndarray
    role: np.ndarray
    facing: np.ndarray
    measured: np.ndarray

    def column(self, track_id: int) -> int | None:
        hits = np.flatnonzero(self.track_ids == track_id)
        return int(hits[0]) if len(hits) else None

    def of(self, track: np.ndarray) -> np.ndarray:
        """(T,) role of the track given per frame by `track (T,)` (-1 or unknown id: UNKNOWN)."""
        out = np.full(len(self.role), UNKNOWN, np.int8)
        for k in np.unique(track[track >= 0]):
            m = self.column(int(k))
            if m is not None:
                rows = track == k
                out[rows] = self.role[rows, m]
        return out

    def with_role(self, role: np.ndarray) -> Roles:
        return Roles(self.track_ids, self.score, role, self.facing, self.measured)


Boxes = dict[int, list[tuple[int, Roi, bool]]]


def faces(
    *,
    multi: MultiPose2D,
    ids: np.ndarray,
    track_ids: np.ndarray,
    config: SpeechConfig,
    head_limits: tuple[float, float] | None = None,
) -> tuple[np.ndarray, Boxes]:
    """(T, M) facing, and per frame the face crops there: frame → [(track column, Roi, whether
    the mouth is measured on it)] (only frames with a crop are keys: a long take with many
    people stays small). head_limits: (largest turn, smallest width px) of the faces that also
    get a crop, for the head only (None: none)."""
    t_n, m_n = len(multi), len(track_ids)
    facing = np.zeros((t_n, m_n), bool)
    boxes: Boxes = {}
    column = {int(k): m for m, k in enumerate(track_ids)}
    for t, p in zip(*np.nonzero(ids >= 0), strict=True):
        m = column.get(int(ids[t, p]))
        if m is None:
            continue
        kp = multi.keypoints[t, p]
        roi, why = face_box(keypoints=kp, skeleton=multi.skeleton, config=config)
        facing[t, m] = why in ("", "face too small")
        mouth = roi is not None
        if roi is None and why != "face unseen" and head_limits is not None:
            turn, px = head_limits
            roi, _ = head_box(
                keypoints=kp,
                skeleton=multi.skeleton,
                min_confidence=config.min_face_confidence,
                max_turn=turn,
                min_px=px,
            )
        if roi is not None:
            boxes.setdefault(int(t), []).append((m, roi, mouth))
    return facing, boxes


@dataclass(frozen=True)
class FaceSamples:
    """What the face model gave on S sampled frames: rows (S,) frame indices; opening (S, M)
    (NaN where a track had no mouth crop there or the model found no face); the head's axes
    (S, M, 3, 3), centre (S, M, 2) and residual (S, M) (`head_pose.HeadFit`; NaN: none)."""

    rows: np.ndarray
    opening: np.ndarray
    axes: np.ndarray
    centre: np.ndarray
    residual: np.ndarray


def measure_faces(
    frames: Iterable[tuple[float, np.ndarray]],
    *,
    timestamps: np.ndarray,
    boxes: Boxes,
    n_tracks: int,
) -> FaceSamples:
    """The face model once per crop on the frames given: mouth openings and head fits. A frame
    whose timestamp is not one of `timestamps` is skipped."""
    model: FaceLandmarker | None = None
    rows: list[int] = []
    values: list[np.ndarray] = []
    axes: list[np.ndarray] = []
    centres: list[np.ndarray] = []
    residuals: list[np.ndarray] = []
    for t, image in frames:
        i = int(np.clip(np.searchsorted(timestamps, t - _MATCH_S), 0, len(timestamps) - 1))
        if abs(float(timestamps[i]) - t) > _MATCH_S:
            continue
        row = np.full(n_tracks, np.nan)
        head = np.full((n_tracks, 3, 3), np.nan)
        centre = np.full((n_tracks, 2), np.nan)
        residual = np.full(n_tracks, np.nan)
        for m, roi, mouth in boxes.get(i, ()):
            model = model or FaceLandmarker()
            mesh = model(image, roi)
            if mouth and mesh.presence >= MIN_FACE_PRESENCE:
                row[m] = mesh.opening
            mesh = model(image, mesh_roi(mesh.points))  # again, on the crop the mesh gives
            if mesh.presence >= MIN_HEAD_PRESENCE:
                fit = fit_head(mesh.points3d)
                head[m], centre[m], residual[m] = fit.axes, fit.centre, fit.residual
        rows.append(i)
        values.append(row)
        axes.append(head)
        centres.append(centre)
        residuals.append(residual)
    if not rows:
        m = n_tracks
        return FaceSamples(
            np.zeros(0, np.int64),
            np.zeros((0, m)),
            np.zeros((0, m, 3, 3)),
            np.zeros((0, m, 2)),
            np.zeros((0, m)),
        )
    return FaceSamples(
        np.asarray(rows, np.int64),
        np.stack(values),
        np.stack(axes),
        np.stack(centres),
        np.stack(residuals),
    )


def measure_openings(
    frames: Iterable[tuple[float, np.ndarray]],
    *,
    timestamps: np.ndarray,
    boxes: Boxes,
    n_tracks: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Mouth openings on the frames given: (rows (S,) frame indices into `timestamps`, opening
    (S, M), NaN where a track had no crop there or the model found no face). A frame whose
    timestamp is not one of `timestamps` is skipped."""
    found = measure_faces(frames, timestamps=timestamps, boxes=boxes, n_tracks=n_tracks)
    return found.rows, found.opening


def sampled_roles(
    *,
    opening: np.ndarray,
    envelope: np.ndarray,
    heard: np.ndarray,
    rate_hz: float,
    config: SpeechConfig,
) -> tuple[np.ndarray, np.ndarray]:
    """Speaking score and role (S, M) on S measured frames of one clock of `rate_hz`:
    opening (S, M), envelope (S,), heard (S,) bool: speech heard just before each frame."""
    score = np.full(opening.shape, np.nan)
    role = np.full(opening.shape, UNKNOWN, np.int8)
    for m in range(opening.shape[1]):
        score[:, m] = speaking_score(
            opening=opening[:, m], envelope=envelope, rate_hz=rate_hz, config=config
        )
    seen = np.isfinite(opening)
    role[seen] = LISTENING
    with np.errstate(invalid="ignore"):
        speaks = seen & heard[:, None] & (score >= config.speaking_threshold)
    role[speaks] = SPEAKING
    return score, role


def heard_before(audio: Audio | None, *, times: np.ndarray, config: SpeechConfig) -> np.ndarray:
    """(S,) bool: speech heard (Silero VAD) within speaking_max_lag_s before each of `times`
    (or at it)."""
    if not len(times):
        return np.zeros(0, bool)
    t0 = float(times[0]) - config.speaking_max_lag_s
    n = math.ceil((float(times[-1]) - t0) * RATE_HZ) + 2
    speech = speech_activity(audio, t0=t0, n_frames=n, config=config).speech
    csum = np.r_[0, np.cumsum(speech)]
    hi = np.clip(np.floor((times - t0) * RATE_HZ).astype(np.int64) + 1, 0, n)
    lo = np.clip(hi - 1 - round(config.speaking_max_lag_s * RATE_HZ), 0, n)
    return np.asarray(csum[hi] - csum[lo] > 0)


def spread(rows: np.ndarray, values: np.ndarray, *, n_frames: int, fill: float | int) -> np.ndarray:
    """(T, ...) each frame takes the value of the nearest of the sampled frames `rows` (S,)."""
    out = np.full((n_frames, *values.shape[1:]), fill, values.dtype)
    if not len(rows):
        return out
    frames = np.arange(n_frames)
    k = np.clip(np.searchsorted(rows, frames), 1, max(1, len(rows) - 1))
    if len(rows) > 1:
        nearer_left = (frames - rows[k - 1]) <= (rows[k] - frames)
        k = np.where(nearer_left, k - 1, k)
    else:
        k = np.zeros(n_frames, np.int64)
    return values[k]


def measure_roles(
    *,
    video: Path,
    multi: MultiPose2D,
    ids: np.ndarray,
    audio: Audio | None,
    video_config: VideoConfig,
    config: SpeechConfig,
    threads: int | None = None,
) -> Roles:
    """The roles of every track of `ids (T, P)` in the frames of `video` that `multi` was
    detected on (`video_config`: the same selection), at most mouth_rate_hz frames a second;
    threads: FFmpeg decoding threads (None: FFmpeg's choice)."""
    roles, _ = measure_people(
        video=video,
        multi=multi,
        ids=ids,
        audio=audio,
        video_config=video_config,
        config=config,
        threads=threads,
        mouths=True,
    )
    assert roles is not None
    return roles


def measure_people(
    *,
    video: Path,
    multi: MultiPose2D,
    ids: np.ndarray,
    audio: Audio | None,
    video_config: VideoConfig,
    config: SpeechConfig,
    threads: int | None = None,
    mouths: bool,
    head_limits: tuple[float, float] | None = None,
) -> tuple[Roles | None, HeadPoses]:
    """Every track's roles (with `mouths`; else None) and head poses (faces within
    `head_limits`, see `faces`; None: the mouths' faces only) from one pass of the face model
    over the frames of `video` that `multi` was detected on (`video_config`: the same
    selection), at most mouth_rate_hz frames a second; the head is interpolated between them.
    threads: FFmpeg decoding threads (None: FFmpeg's choice)."""
    from gesturebank.extract.video import iter_frames

    ts = np.asarray(multi.timestamps, np.float64)
    track_ids = np.unique(ids[ids >= 0]).astype(np.int64)
    m_n, t_n = len(track_ids), len(ts)
    facing, boxes = faces(
        multi=multi, ids=ids, track_ids=track_ids, config=config, head_limits=head_limits
    )
    if not mouths:  # the head's crops only
        boxes = {t: [(m, roi, False) for m, roi, _ in b] for t, b in boxes.items()}
    found = measure_faces((), timestamps=ts, boxes={}, n_tracks=m_n)
    if boxes:  # else nothing to measure: no decoding
        cap = config.mouth_rate_hz
        selection = video_config.model_copy(
            update={"max_fps": min(cap, video_config.max_fps or cap)}
        )
        found = measure_faces(
            iter_frames(video, selection, threads=threads), timestamps=ts, boxes=boxes, n_tracks=m_n
        )
    heads = HeadPoses(track_ids, *spread_heads(found.rows, found.axes, centre=found.centre,
                                               residual=found.residual, n_frames=t_n))  # fmt: skip
    if not mouths:
        return None, heads
    rows, opening = found.rows, found.opening
    score = np.full((t_n, m_n), np.nan, np.float32)
    role = np.full((t_n, m_n), UNKNOWN, np.int8)
    measured = np.zeros((t_n, m_n), bool)
    if len(rows) >= 2 and audio is not None:
        times = ts[rows]
        rate = 1.0 / float(np.median(np.diff(times)))
        env = np.nan_to_num(
            speech_envelope(audio=audio, timestamps=times, smooth_s=ENVELOPE_SMOOTH_S)
        )
        heard = heard_before(audio, times=times, config=config)
        s, r = sampled_roles(
            opening=opening, envelope=env, heard=heard, rate_hz=rate, config=config
        )
        score = spread(rows, s.astype(np.float32), n_frames=t_n, fill=np.nan)
        role = spread(rows, r, n_frames=t_n, fill=UNKNOWN)
    elif len(rows):
        role = spread(
            rows,
            np.where(np.isfinite(opening), LISTENING, UNKNOWN).astype(np.int8),
            n_frames=t_n,
            fill=UNKNOWN,
        )
    measured[rows] = np.isfinite(opening)
    # Nobody's role where they are not in the picture.
    column = {int(k): m for m, k in enumerate(track_ids)}
    present = np.zeros((t_n, m_n), bool)
    for t, p in zip(*np.nonzero(ids >= 0), strict=True):
        present[t, column[int(ids[t, p])]] = True
    role[~present] = UNKNOWN
    score[~present] = np.nan
    return Roles(track_ids, score, role, facing, measured), heads
