"""One take through the whole pipeline into clips (docs/architecture.md "Data flow").

extract (decode, detect everybody + shot cuts — cached —, the main speaker per shot, audio) →
repair the main speaker's keypoints → speech activity over the take (`extract.vad`) → cut the
take into clips (shots, speaker changes, absences and unusable stretches, audio, silences over
`speech.max_silence_s`, `clips.min_s`) → per clip: lift, Pepper angles (masked where a
limb was not seen), the 100 Hz processing, audio features on the same clock, QC metrics and the
absolute verdict. The dataset-relative verdicts come later, over every clip (`datasets.refresh`).
Raises on failure; the builder turns that into a `failed` record.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import logging
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from gesturebank.clip import Clip, kept_parts, part_mask
from gesturebank.config import Config, ProcessingConfig
from gesturebank.datasets.cut import Span, cut_clips, frame_ends, trimmed_share
from gesturebank.datasets.judging import judged_records
from gesturebank.datasets.partners import pair_clips
from gesturebank.datasets.process import process_angles
from gesturebank.datasets.store import ClipRecord, TakeRecord
from gesturebank.datasets.takes import Take
from gesturebank.errors import InputError
from gesturebank.extract.audio_io import Audio
from gesturebank.extract.vad import RATE_HZ, SpeechActivity, silences, speech_activity
from gesturebank.filters import butter_lowpass, interpolate_at
from gesturebank.lift.depth_confidence import pose_confidence
from gesturebank.poses import Pose2D, Pose3D
from gesturebank.qc.metrics import measure_settings, spike_sizes
from gesturebank.repair import repair_pose2d, repair_pose3d, validity
from gesturebank.repair.snaps import others_of, unsnap
from gesturebank.robot import pepper
from gesturebank.skeletons import COCO17, get_skeleton, to_coco17

if TYPE_CHECKING:
    from gesturebank.extract.cache import DetectionCache
    from gesturebank.extract.tracking import Tracked, TrackReport
    from gesturebank.poses import MultiPose2D

_I = COCO17.index
log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BuiltTake:
    """A take's record, its clips and its preview strip (JPEG bytes)."""

    record: TakeRecord
    clips: tuple[Clip, ...]
    preview: bytes | None
    detect_s: float


@dataclass(frozen=True)
class _View:
    """What the clips are cut from: the main speaker on the take's (reference) frames (of a
    multi-camera take, pose2d is the reference camera's, drawn but not judged: `_multi_view`).

    valid / repaired: (T, 17) COCO-17 bools; speaker: (T,) the person's track id (the main
    speaker's, or one person's with build.people = "all"); role: (T,) int8 their role code
    (clip.ROLES); lift(a, b): the 3D pose of frames [a, b) (lifted per clip for one camera,
    sliced for several)."""

    pose2d: Pose2D
    valid: np.ndarray
    repaired: np.ndarray
    repairs: dict[str, int]
    cuts: np.ndarray
    speaker: np.ndarray
    role: np.ndarray
    n_people: np.ndarray
    change: np.ndarray
    audio: Audio
    lift: Callable[[int, int], Pose3D]
    detector: str
    lifter: str
    video_fps: float
    detect_s: float
    tracking: dict[str, Any]
    preview: tuple[tuple[float, np.ndarray], ...]


def check_names(config: Config) -> None:
    """The detector, lifter and robot profile a build uses by name, checked before any take
    starts (a typo is one usage error, not a failure of every take); imports no model."""
    from gesturebank.extract.detectors import DETECTORS
    from gesturebank.lift import LIFTERS

    DETECTORS.check(config.detector.name)
    LIFTERS.check(config.lifter.name)
    pepper.load_profile(config.robot.profile)


def lifter_name(take: Take, config: Config) -> str:
    """The lifter of `take`: `lifter.name`, except that a multi-camera take is triangulated."""
    if take.mocap:
        return MOCAP
    return "multiview" if take.multi_camera else config.lifter.name


def measure_digest(config: Config) -> str:
    """What the stored metrics were measured with (qc.metrics.measure_settings)."""
    text = json.dumps(
        {"qc": measure_settings(config.qc), "robot": config.robot.profile}, sort_keys=True
    )
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _tracking_json(report: TrackReport) -> dict[str, Any]:
    """The main-speaker report for the take record, without its per-frame arrays (the clips
    hold what matters of them; a long take would make the record large)."""
    data = report.to_json_dict()
    return {k: v for k, v in data.items() if k not in ("main_ids", "n_people")}


def _coco17_mask(mask: np.ndarray, skeleton: str) -> np.ndarray:
    """`(T, K)` bools of `skeleton` → `(T, 17)` COCO-17 (joints it lacks: False)."""
    out = get_skeleton(skeleton).convert(mask[..., None].astype(np.float32), COCO17)[..., 0]
    return np.nan_to_num(out, nan=0.0) > 0.5


def still_spiking(points: np.ndarray, valid: np.ndarray, max_spike: float) -> np.ndarray:
    """`(T, 17)` COCO-17 keypoints of `points (T, 17, C)` that, seen (`valid`), still jump out
    and back by more than `max_spike` shoulder widths in one frame (what repair left)."""
    seen = np.where(valid[..., None], np.asarray(points, np.float64), np.nan)
    out = np.zeros(valid.shape, dtype=bool)
    with np.errstate(invalid="ignore"):
        out[1:-1] = spike_sizes(seen, COCO17.joints) > max_spike
    return out


def usable_frames(valid: np.ndarray) -> np.ndarray:
    """`(T,)` frames whose pose is worth keeping: both shoulders seen, and the face or an elbow
    (`valid (T, 17)` COCO-17). Other frames inside a clip are masked; long runs end it."""
    torso = valid[:, _I["left_shoulder"]] & valid[:, _I["right_shoulder"]]
    face = valid[:, [_I["nose"], _I["left_eye"], _I["right_eye"]]].all(axis=1)
    arm = valid[:, _I["left_elbow"]] | valid[:, _I["right_elbow"]]
    return np.asarray(torso & (face | arm))


def _single_views(take: Take, config: Config, chunks: DetectionCache | None) -> list[_View]:
    """One camera: the main speaker's view, or with build.people = "all" one view per tracked
    person (by track id)."""
    from gesturebank.extract.identity import gather
    from gesturebank.extract.pipeline import extract_take
    from gesturebank.lift import LIFTERS

    if config.lifter.name == "multiview":  # known before the slow extraction starts
        raise InputError(
            f"{take.video}: the multiview lifter needs a multi-camera take (a folder with a "
            "calibration file and two or more videos)"
        )
    ext = extract_take(take.video, config, chunks=chunks)
    if ext.audio is None:
        raise InputError(f"{take.video}: no audio track and no {take.video.stem}.wav beside it")
    lifter = LIFTERS.create(lifter_name(take, config), config)
    ids = ext.tracked.ids
    if config.build.people == "all":
        tracks = [np.full(len(ext.multi), int(k), np.int64) for k in np.unique(ids[ids >= 0])]
    else:
        tracks = [ext.tracked.report.main_ids]
    views = []
    for track in tracks:
        # a joint snapped onto another person for 1-3 frames is set missing first (issue 41)
        own, snapped = unsnap(
            gather(ext.multi, ids, track), others_of(ext.multi, ids, track), config=config.repair
        )
        pose, report = repair_pose2d(own, config=config.repair)
        valid = _coco17_mask(
            validity(pose, visible_confidence=config.repair.visible_confidence), pose.skeleton
        )
        xy = to_coco17(pose.keypoints, pose.skeleton)[..., :2]
        valid &= ~still_spiking(xy, valid, config.repair.max_spike)
        views.append(
            _View(
                pose2d=pose,
                valid=valid,
                repaired=_coco17_mask(report.repaired | snapped, pose.skeleton),
                repairs={**report.counts(), "snaps": int(snapped.sum())},
                cuts=ext.shots.cuts,
                speaker=track,
                role=ext.tracked.role_of(track),
                n_people=ext.multi.present.sum(axis=1),
                change=ext.shots.change,
                audio=ext.audio,
                lift=_lift_frames(lifter, pose),
                detector=ext.info.detector,
                lifter=lifter_name(take, config),
                video_fps=ext.info.video.fps,
                detect_s=ext.info.detect_seconds,
                tracking={
                    **_tracking_json(ext.tracked.report),
                    "mouth_seconds": ext.info.mouth_seconds,
                    "people": people_summary(ext.multi, ext.tracked),
                },
                preview=ext.preview,
            )
        )
    return views


def people_summary(multi: MultiPose2D, tracked: Tracked) -> dict[str, dict[str, Any]]:
    """Per track id: seconds seen, share of those facing the camera and seconds speaking, and
    where in the image (median upper-body centre, shares of width and height) — what a
    `<stem>.people.toml` names a person by."""
    from gesturebank.extract.roles import SPEAKING
    from gesturebank.extract.speech import frame_step

    ids, step = tracked.ids, frame_step(multi.timestamps)
    w, h = multi.image_size
    out: dict[str, dict[str, Any]] = {}
    for k in np.unique(ids[ids >= 0]):
        mask = ids == k
        seen = mask.any(axis=1)
        xy = np.where(multi.keypoints[..., 2:3] > 0, multi.keypoints[..., :2], np.nan)[mask]
        with warnings.catch_warnings():  # a person without a confident keypoint: NaN centre
            warnings.simplefilter("ignore", RuntimeWarning)
            centre = np.nanmedian(np.nanmean(xy, axis=1), axis=0)
        entry: dict[str, Any] = {
            "seen_s": round(float(seen.sum() * step), 2),
            "at": [round(float(centre[0] / w), 3), round(float(centre[1] / h), 3)],
        }
        roles = tracked.roles
        m = None if roles is None else roles.column(int(k))
        if roles is not None and m is not None:
            entry["facing"] = round(float(roles.facing[seen, m].mean()), 3)
            entry["speaking_s"] = round(float((roles.role[:, m] == SPEAKING).sum() * step), 2)
        out[str(int(k))] = entry
    return out


def _lift_frames(lifter: Any, pose: Pose2D) -> Callable[[int, int], Pose3D]:
    """Frames [a, b) of `pose` lifted to 3D by the single-camera `lifter`."""
    from gesturebank.lift import TakeViews

    return lambda a, b: lifter.lift(TakeViews.of(pose.frames(a, b)))


def _multi_view(take: Take, config: Config, chunks: DetectionCache | None) -> _View:
    """A multi-camera take: every camera detected and repaired, triangulated by the multi-view
    lifter. The reference camera's clock, shots and speaker stand for the take, its 2D pose is
    kept to be drawn; the QC judges the 3D as every camera sees it (the cameras travel in the
    3D pose's `cameras`, set by the lifter), not the reference camera's 2D. The
    audio is a .wav beside the videos, else the camera track with the most energy, moved onto
    the reference clock by the camera offsets the lifter used."""
    from gesturebank.extract.audio_io import read_audio
    from gesturebank.extract.pipeline import extract_take
    from gesturebank.lift import LIFTERS, TakeViews
    from gesturebank.lift.multiview.cameras import CameraGroup
    from gesturebank.lift.multiview.lifter import MultiviewLifter, match_cameras

    assert take.calibration is not None
    # any subset of the calibrated cameras, by name (a broken camera left out)
    cameras, videos = match_cameras(CameraGroup.load(take.calibration), take.videos)
    exts = [extract_take(v, config, chunks=chunks) for v in videos]
    repaired = [repair_pose2d(e.tracked.pose, config=config.repair) for e in exts]
    poses = [pose for pose, _ in repaired]
    audios = [e.audio for e in exts]
    lifter = LIFTERS.create(lifter_name(take, config), config)
    assert isinstance(lifter, MultiviewLifter)  # the audio choice below needs its camera offsets
    pose3d, report = lifter.lift_with_report(TakeViews(tuple(poses), cameras, tuple(audios)))
    pose3d, report3d = repair_pose3d(pose3d, config=config.repair)
    ref = config.multiview.reference_camera
    if take.audio is not None:
        audio = read_audio(take.audio, sample_rate=config.audio.sample_rate)
        if audio is None:
            raise InputError(f"{take.audio}: no audio in this file")
        audio = audio._replace(start_s=float(poses[ref].timestamps[0]))  # recorded with the video
    else:
        tracks = [(c, a) for c, a in enumerate(audios) if a is not None and len(a.signal)]
        if not tracks:
            raise InputError(
                f"{take.video}: no camera has an audio track and no .wav is beside them"
            )
        c, best = max(tracks, key=lambda ca: float(np.mean(np.square(ca[1].signal))))
        audio = best._replace(start_s=best.start_s - float(report.offsets_s[c]))
    # A triangulated joint counts as seen; the repair's counts are those of the 3D pose.
    valid = np.isfinite(pose3d.joints).all(axis=-1) & (np.nan_to_num(pose3d.confidence) > 0)
    e = exts[ref]
    return _View(
        pose2d=poses[ref],
        valid=valid,
        repaired=report3d.repaired,
        repairs=report3d.counts(),
        cuts=e.shots.cuts,
        speaker=e.tracked.report.main_ids,
        role=e.tracked.role_of(e.tracked.report.main_ids),
        n_people=e.multi.present.sum(axis=1),
        change=e.shots.change,
        audio=audio,
        lift=lambda a, b: pose3d.frames(a, b),
        detector=e.info.detector,
        lifter=lifter_name(take, config),
        video_fps=e.info.video.fps,
        detect_s=sum(x.info.detect_seconds for x in exts),
        tracking=_tracking_json(e.tracked.report),
        preview=e.preview,
    )


MOCAP = "mocap"  # the "lifter" and "detector" of a motion-capture take: its 3D is measured
MOCAP_PX_PER_M = 400.0  # the front view drawn for a mocap take (QC, dashboard), pixels per metre


def _front_view(pose3d: Pose3D) -> Pose2D:
    """A mocap take seen by an orthographic camera in front of the speaker (their mean facing
    direction), image y down; the frame fits the body. The 2D checks (facing away, sideways,
    swaps) then judge the motion as they judge a video's."""
    from gesturebank.mocap.pose import body_axes

    _, left, up = body_axes(pose3d.joints)
    xy = np.stack([pose3d.joints @ left, -(pose3d.joints @ up)], axis=-1) * MOCAP_PX_PER_M
    low = np.nanmin(xy, axis=(0, 1))
    margin = 0.25 * MOCAP_PX_PER_M
    xy = xy - low + margin
    size = np.nanmax(xy, axis=(0, 1)) + margin
    keypoints = np.concatenate([xy, pose3d.confidence[..., None]], axis=-1)
    return Pose2D(keypoints, pose3d.timestamps, COCO17.name, (int(size[0]), int(size[1])))


def _mocap_view(take: Take, config: Config) -> _View:
    """A motion-capture take: the BVH's forward kinematics is the 3D pose (no detector, no
    lifter), one speaker, one shot; its audio starts with the first frame."""
    import time

    from gesturebank.extract.audio_io import read_audio
    from gesturebank.mocap.bvh import read_bvh
    from gesturebank.mocap.pose import motion_pose

    start = time.perf_counter()
    if take.audio is None:
        raise InputError(
            f"{take.video}: no {take.video.stem}.wav beside it and no audio column in "
            "subjects.csv for this take"
        )
    pose3d, joints = motion_pose(read_bvh(take.video), config=config.mocap, source=str(take.video))
    audio = read_audio(take.audio, sample_rate=config.audio.sample_rate)
    if audio is None:
        raise InputError(f"{take.audio}: no audio in this file")
    pose2d = _front_view(pose3d)
    t = len(pose3d)
    return _View(
        pose2d=pose2d,
        valid=np.isfinite(pose3d.joints).all(axis=-1),
        repaired=np.zeros((t, len(COCO17)), dtype=bool),
        repairs={},
        cuts=np.zeros(0),
        speaker=np.zeros(t, dtype=np.int64),
        role=np.zeros(t, dtype=np.int8),  # unknown: no video to see who speaks
        n_people=np.ones(t, dtype=np.int64),
        change=np.full(t, np.nan),  # no image: the still-picture check does not apply
        audio=audio._replace(start_s=0.0),
        lift=lambda a, b: pose3d.frames(a, b),
        detector=MOCAP,
        lifter=MOCAP,
        video_fps=1.0 / float(np.median(np.diff(pose3d.timestamps))) if t > 1 else 0.0,
        detect_s=time.perf_counter() - start,
        tracking={
            "source": "bvh",
            "joints": joints,
            "metres_per_unit": pose3d.meta["metres_per_unit"],
        },
        preview=(),
    )


def audio_clock(
    pose_t: np.ndarray, audio_start_s: float, n_frames: int, hop_s: float, win_s: float
) -> tuple[int, int, np.ndarray]:
    """Audio frames whose window centre lies within the pose's time span.

    Frame i covers [start + i·hop, start + i·hop + win) (audio_features), so its centre is at
    start + i·hop + win/2. Returns (i0, i1, times (i1 − i0 + 1,)) — the common span of audio and
    video on the audio frame clock; InputError when they do not overlap.
    """
    c0 = audio_start_s + win_s / 2
    eps = 1e-9  # timestamps that land on a frame centre up to float rounding count as inside
    i0 = max(0, math.ceil((pose_t[0] - c0) / hop_s - eps))
    i1 = min(n_frames - 1, math.floor((pose_t[-1] - c0) / hop_s + eps))
    if i1 < i0:
        raise InputError("audio and video do not overlap in time")
    return i0, i1, c0 + hop_s * np.arange(i0, i1 + 1)


def covering(audio: Audio, timestamps: np.ndarray, *, margin_s: float) -> Audio:
    """`audio` zero-padded (digital silence) to cover the video's frames `timestamps` and
    `margin_s` either side: time without audio (a late or short track) is silence, cut or
    marked by the silence rule (`speech.max_silence_s`) like any other."""
    sr = audio.sample_rate
    before = max(0, math.ceil((audio.start_s - float(timestamps[0]) + margin_s) * sr))
    end = audio.start_s + len(audio.signal) / sr
    after = max(0, math.ceil((float(frame_ends(timestamps)[-1]) + margin_s - end) * sr))
    if not before and not after:
        return audio
    signal = np.pad(np.asarray(audio.signal, np.float32), (before, after))
    return audio._replace(signal=signal, start_s=audio.start_s - before / sr)


def _clip(
    view: _View,
    span: Span,
    clip_id: str,
    take_id: str,
    feats: np.ndarray,
    feats_start_s: float,
    activity: SpeechActivity,
    config: Config,
    profile: pepper.RobotProfile,
) -> Clip:
    """The arrays of frames [span.start, span.stop) on the clip's own clock; `feats` are the
    audio features of the (padded, `covering`) track whose sample 0 is at `feats_start_s`."""
    from gesturebank.robot.retarget import angle_support, head_roll, pepper_angles

    a, b = span.start, span.stop
    ts = view.pose2d.timestamps[a:b]
    a_cfg = config.audio
    i0, i1, times = audio_clock(ts, feats_start_s, len(feats), a_cfg.winstep_s, a_cfg.winlen_s)
    pose3d = view.lift(a, b)
    if view.lifter not in ("multiview", MOCAP):  # a lifter's own glitches (multiview: repaired)
        pose3d, _ = repair_pose3d(pose3d, config=config.repair)
    valid = view.valid[a:b] & ~still_spiking(
        pose3d.joints, view.valid[a:b], config.repair.max_spike
    )
    raw = pepper_angles(pose3d, config=config.retarget)
    support = angle_support(valid)
    raw[~support] = np.nan
    pose2d = view.pose2d.frames(a, b, origin_s=float(times[0]))
    processed = process_angles(
        raw=raw,
        timestamps=ts,
        clock=times,
        processing=config.processing,
        retarget=config.retarget,
        profile=profile,
    )
    # Each body part judged on its own (issue 32): one seen too little is masked whole.
    parts = kept_parts(
        processed.mask, max_part_unseen_fraction=config.clips.max_part_unseen_fraction
    )
    keep = part_mask(parts)
    mask = processed.mask & keep
    roll = head_roll(pose3d)
    roll[~support[:, pepper.INDEX["HeadPitch"]]] = np.nan
    known = mask[:, pepper.INDEX["HeadPitch"]]
    clock = {"timestamps": ts, "clock": times, "known": known}
    roll100 = head_roll_at(roll, **clock, processing=config.processing)
    start_s = float(times[0])
    return Clip(
        clip_id=clip_id,
        take_id=take_id,
        start_s=start_s,
        angles=np.where(keep, processed.angles, np.nan).astype(np.float32),
        angles01=np.where(keep, processed.angles01, np.nan).astype(np.float32),
        mask=mask,
        audio=feats[i0 : i1 + 1],
        times=times - start_s,
        speech=speech_at(activity, times),
        raw_angles=raw,
        timestamps=ts - start_s,
        pose2d=pose2d,
        pose3d=pose3d.frames(0, len(pose3d), origin_s=start_s),
        valid=valid,
        repaired=view.repaired[a:b],
        n_people=view.n_people[a:b].astype(np.int16),
        change=np.asarray(view.change[a:b], dtype=np.float32),
        head_roll=roll100,
        depth_confidence=lift_confidence(pose2d, pose3d, lifter=view.lifter),
        person=int(view.speaker[a]),
        role=role_at(view.role[a:b], ts, times),
        partner_clip_id="",  # set for the whole take (`datasets.partners.pair_clips`)
        partner_speaking=np.zeros(len(times), bool),
    )


def head_roll_at(
    roll: np.ndarray,
    *,
    timestamps: np.ndarray,
    clock: np.ndarray,
    known: np.ndarray,
    processing: ProcessingConfig,
) -> np.ndarray:
    """`roll (T,)` rad at the video's `timestamps` → `(N,)` float32 on the 100 Hz `clock`, as
    the head's angles are processed (short gaps interpolated, the same low-pass; no robot
    limits: Pepper has no roll joint), NaN where the head is not `known (N,)`."""
    values, _ = interpolate_at(roll[:, None], timestamps, clock, max_gap_s=processing.max_gap_s)
    smooth = butter_lowpass(
        values, processing.rate_hz, cutoff_hz=processing.cutoff_hz, order=processing.butter_order
    )[:, 0]
    return np.where(known, smooth, np.nan).astype(np.float32)


def lift_confidence(pose2d: Pose2D, pose3d: Pose3D, *, lifter: str) -> np.ndarray:
    """(T,) float32 depth confidence of a clip's lift (`lift.depth_confidence`): 1 where the 3D
    was measured (several cameras, motion capture), else from the view's 2D and the lift."""
    if lifter in ("multiview", MOCAP):
        return np.ones(len(pose3d), np.float32)
    coco = pose2d.to_coco17().keypoints.astype(np.float64)
    return pose_confidence(xy=coco[..., :2], joints=pose3d.joints)


NOBODY_SPEAKS = "nobody speaks: several people and no mouth follows the speech"


def _why_dropped(span: Span, view: _View) -> str:
    """A span's reason; "main speaker absent" where people were there but nobody was made the
    speaker (dubbed speech over several people) says so."""
    a, b = span.start, max(span.stop, span.start + 1)
    nobody = (view.speaker[a:b] < 0).all() and view.n_people[a:b].max(initial=0) >= 2
    return NOBODY_SPEAKS if span.reason == "main speaker absent" and nobody else span.reason


def role_at(role: np.ndarray, timestamps: np.ndarray, times: np.ndarray) -> np.ndarray:
    """(N,) int8: the role of the video frame shown at each of `times` (the last one starting
    at or before it; the first frame for times before it)."""
    k = np.searchsorted(np.asarray(timestamps), np.asarray(times) + 1e-9, side="right") - 1
    return np.asarray(role, np.int8)[np.clip(k, 0, len(role) - 1)]


def take_activity(audio: Audio, timestamps: np.ndarray, config: Config) -> SpeechActivity:
    """Speech activity over the whole take (first frame to the last frame's end), on the video's
    clock: the VAD runs once per take, its recurrent state carried across clip boundaries."""
    t0 = float(timestamps[0])
    n = math.ceil((float(frame_ends(timestamps)[-1]) - t0) * RATE_HZ) + 1
    return speech_activity(audio, t0=t0, n_frames=n, config=config.speech)


def speech_at(activity: SpeechActivity, times: np.ndarray) -> np.ndarray:
    """(N,) bool: `activity`'s speech at `times` (s, its clock); outside it, silence."""
    k = np.floor((np.asarray(times, np.float64) - activity.t0) * activity.rate_hz + 1e-9)
    inside = (k >= 0) & (k < len(activity.speech))
    out = np.zeros(len(k), bool)
    out[inside] = activity.speech[k[inside].astype(np.int64)]
    return out


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
    take: Take, source: str, config: Config, *, chunks: DetectionCache | None = None
) -> BuiltTake:
    """Every clip of one take, its record (clips, dropped spans, QC metrics and absolute
    verdicts) and its preview; raises a GesturebankError when the take cannot be built.
    chunks: where videos longer than build.chunk_s find their chunks' detections (None: every
    video is detected in one pass)."""
    from gesturebank.extract.audio_features import features

    if take.mocap:
        views = [_mocap_view(take, config)]
    elif take.multi_camera:  # people are not matched across cameras: the main speaker only
        views = [_multi_view(take, config, chunks)]
    else:
        views = _single_views(take, config, chunks)
    view = views[0]  # the audio, clock, detector and preview are the take's, the same in each
    profile = pepper.load_profile(config.robot.profile)
    ts = view.pose2d.timestamps
    audio_end = view.audio.start_s + len(view.audio.signal) / view.audio.sample_rate
    audio_span = (float(view.audio.start_s), float(audio_end))
    # missing audio is silence (issue 32): features over digital silence where the track is not
    heard = covering(view.audio, ts, margin_s=config.audio.winlen_s)
    feats = features(heard.signal, heard.sample_rate, config.audio)
    activity = take_activity(view.audio, ts, config)
    trimmed = trimmed_share(ts, audio_span)  # judged on every clip (qc.max_trimmed_fraction)
    if trimmed > config.qc.max_trimmed_fraction:
        log.warning(
            "%s: audio and video overlap for %.0f%% of the video; trimming to their common span "
            "drops %.0f%% of it (more than qc.max_trimmed_fraction %.0f%%)",
            *(take.audio or take.video, 100 * (1 - trimmed), 100 * trimmed),
            100 * config.qc.max_trimmed_fraction,
        )
    measured = measure_digest(config)
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
            whole = _clip(
                person_view,
                span,
                f"{take.take_id}__whole",
                take.take_id,
                feats,
                heard.start_s,
                activity,
                config,
                profile,
            )
            # judged, and cut around the stretches that fail (issue 41); trimmed_fraction is of
            # the whole take, so each of its clips carries it
            kept, judged = judged_records(
                whole,
                config=config,
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
    return BuiltTake(record, tuple(clips), _preview_jpeg(view.preview), view.detect_s)


def _audio_sums(feats: list[np.ndarray], dim: int) -> dict[str, object]:
    """Frame count and per-feature sums of every clip's features: the z-norm stats of a subject
    combine these over its takes without loading any clip again."""
    stacked = np.concatenate(feats).astype(np.float64) if feats else np.zeros((0, dim))
    return {
        "n": len(stacked),
        "sum": stacked.sum(axis=0).tolist(),
        "sumsq": np.square(stacked).sum(axis=0).tolist(),
    }


def content_digest(config: Config) -> str:
    """What a take's content was built with: the CONTENT_SECTIONS, and build.people when it is
    not the default (the one build key that changes what a take holds; so datasets built with
    the default keep their digest)."""
    digest = config.digest(*CONTENT_SECTIONS)
    if config.build.people == "speaker":
        return digest
    return hashlib.sha256(f"{digest} people={config.build.people}".encode()).hexdigest()[:16]


# Config sections that change what a take contains. The others only change how it is built
# (build), judged (qc), split (splits), calibrated (board), trained on (train), played
# (playback) or drawn (render, synth); speech sets each clip's `speech` and cuts long silences;
# tests/datasets/test_build.py checks each is one or the other.
NOT_CONTENT_SECTIONS = (
    "build",
    "qc",
    "splits",
    "board",
    "train",
    "playback",
    "render",
    "synth",
)
CONTENT_SECTIONS = (
    "video",
    "detector",
    "shots",
    "tracking",
    "repair",
    "clips",
    "lifter",
    "geometric",
    "fitted",
    "resolved",
    "learned",
    "multiview",
    "robot",
    "retarget",
    "processing",
    "audio",
    "mocap",
    "speech",
)
