"""One clip of a take's view: lifted, retargeted, processed at 100 Hz, with the audio features
on the same clock (docs/architecture.md "Data flow")."""

from __future__ import annotations

import math

import numpy as np

from gesturebank.app.views import TakeView
from gesturebank.audio.io import Audio
from gesturebank.audio.vad import RATE_HZ, SpeechActivity, speech_activity
from gesturebank.clip import Clip, kept_parts, part_mask
from gesturebank.config import Config
from gesturebank.datasets.cut import Span, frame_ends
from gesturebank.datasets.head import in_pose_frame, mix_head
from gesturebank.datasets.process import head_roll_at, process_angles
from gesturebank.errors import InputError
from gesturebank.lift.clip_confidence import lift_confidence, lifter_traits
from gesturebank.qc.usable import still_spiking
from gesturebank.repair import repair_pose3d
from gesturebank.robot import pepper
from gesturebank.skeletons import COCO17

_I = COCO17.index


def audio_clock(
    pose_t: np.ndarray, audio_start_s: float, *, n_frames: int, hop_s: float, win_s: float
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


def build_clip(
    view: TakeView,
    span: Span,
    *,
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
    i0, i1, times = audio_clock(
        ts, feats_start_s, n_frames=len(feats), hop_s=a_cfg.winstep_s, win_s=a_cfg.winlen_s
    )
    pose3d = view.lift(a, b)
    if not lifter_traits(view.lifter).measured_depth:  # a lifter's own glitches (measured 3D:
        # triangulated and repaired by its lifter, or motion capture)
        pose3d, _ = repair_pose3d(pose3d, config=config.repair)
    valid = view.valid[a:b] & ~still_spiking(
        pose3d.joints, view.valid[a:b], max_spike=config.repair.max_spike
    )
    raw = pepper_angles(pose3d, config=config.retarget)
    support = angle_support(valid)
    raw[~support] = np.nan
    face = view.face.frames(a, b) if view.face is not None else None
    raw, roll, head_source = mix_head(
        pose3d=pose3d,
        raw=raw,
        roll=head_roll(pose3d),
        body_ok=support[:, pepper.INDEX["HeadPitch"]],
        torso_ok=valid[:, _I["left_shoulder"]] & valid[:, _I["right_shoulder"]],
        face_axes=None
        if face is None
        else in_pose_frame(face.axes, pose3d=pose3d, camera=view.camera),
        face_ok=np.zeros(b - a, bool)
        if face is None
        else face.residual <= config.retarget.head_max_fit_residual,
    )
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
        depth_confidence=lift_confidence(pose2d=pose2d, pose3d=pose3d, lifter=view.lifter),
        person=int(view.speaker[a]),
        role=role_at(view.role[a:b], ts, times=times),
        head_source=head_source,
        partner_clip_id="",  # set for the whole take (`datasets.partners.pair_clips`)
        partner_speaking=np.zeros(len(times), bool),
    )


def role_at(role: np.ndarray, timestamps: np.ndarray, *, times: np.ndarray) -> np.ndarray:
    """(N,) int8: the role of the video frame shown at each of `times` (the last one starting
    at or before it; the first frame for times before it)."""
    k = np.searchsorted(np.asarray(timestamps), np.asarray(times) + 1e-9, side="right") - 1
    return np.asarray(role, np.int8)[np.clip(k, 0, len(role) - 1)]


def take_activity(audio: Audio, timestamps: np.ndarray, *, config: Config) -> SpeechActivity:
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
