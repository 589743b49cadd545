"""Synthetic clips and dataset folders for tests and benchmarks (not used by the product).

`clip_from_angles` turns Pepper angles into a complete `Clip` the way a real take would give
one: the robot's forward kinematics give COCO-17 joints, a frontal orthographic camera gives the
2D keypoints, and the 100 Hz angles come from `datasets.process`. `write_dataset` writes clips
with the real store and `datasets.refresh`, so the folder is like any built dataset.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from gesturebank.clip import Clip, part_columns
from gesturebank.config import Config, ProcessingConfig
from gesturebank.datasets import store
from gesturebank.datasets.digest import CONTENT_SECTIONS, measure_digest
from gesturebank.datasets.process import process_angles
from gesturebank.datasets.refresh import refresh
from gesturebank.poses import Pose2D, Pose3D
from gesturebank.robot import pepper
from gesturebank.robot.retarget import pepper_angles
from gesturebank.skeletons import COCO17

IMAGE_SIZE = (1280, 720)
PX_PER_M = 400.0


def _filmed(
    joints: np.ndarray, timestamps: np.ndarray, *, clip_id: str, angles: dict[str, np.ndarray]
) -> Clip:
    """A clip of the person `joints (T, 17, 3)` (robot frame, m; NaN = unseen) filmed from the
    front by an orthographic camera at `timestamps`, with the 100 Hz arrays `angles` (angles,
    angles01, mask, audio, times) and raw_angles."""
    # seen from the front: the robot's left (+y) is the image's right
    xy = np.stack([640 + PX_PER_M * joints[..., 1], 360 - PX_PER_M * joints[..., 2]], axis=-1)
    conf = np.where(np.isfinite(xy[..., 0]), 1.0, np.nan)[..., None]
    valid = np.asarray(np.isfinite(joints).all(axis=-1))
    n = len(timestamps)
    head = np.asarray(angles["mask"])[:, part_columns("head")].any(axis=1)
    return Clip(
        clip_id=clip_id,
        take_id=clip_id.rsplit("__", 1)[0],
        start_s=0.0,
        timestamps=timestamps,
        pose2d=Pose2D(np.concatenate([xy, conf], axis=-1), timestamps, COCO17.name, IMAGE_SIZE),
        pose3d=Pose3D(joints, conf[..., 0], timestamps, frame="robot", units="m"),
        valid=valid,
        repaired=np.zeros_like(valid),
        n_people=np.ones(n, np.int16),
        change=np.full(n, 1.0, np.float32),
        speech=np.ones(len(angles["times"]), bool),  # a speaker heard throughout
        head_roll=np.where(head, 0.0, np.nan).astype(np.float32),  # Pepper's FK: a level head
        depth_confidence=np.ones(n, np.float32),  # the joints are exact: nothing to doubt
        partner_clip_id="",
        partner_speaking=np.zeros(len(angles["times"]), bool),
        **angles,  # type: ignore[arg-type]
    )


def clip_from_angles(
    angles: np.ndarray,
    timestamps: np.ndarray,
    *,
    clip_id: str = "synthetic__c000",
    audio: np.ndarray | None = None,
    config: Config | None = None,
) -> Clip:
    """A clip whose speaker moves as `angles (T, 11)` rad at `timestamps (T,)` s (from 0): the
    robot's forward kinematics give the joints, the builder's processing the 100 Hz angles.

    audio: (N, F) features on the 100 Hz clock (default: 26 zeros per frame); NaN angles make
    the joints they move unknown (NaN, unseen)."""
    c = config or Config()
    ts = np.asarray(timestamps, dtype=np.float64)
    profile = pepper.load_profile(c.robot.profile)
    joints = pepper.fk_coco17(np.nan_to_num(np.asarray(angles, np.float64))).astype(np.float32)
    # FK has no legs: put knees and ankles under the hips so a 2D view "sees" them
    joints[:, 13:15] = joints[:, 11:13] - [0, 0, 0.4]
    joints[:, 15:17] = joints[:, 11:13] - [0, 0, 0.8]
    joints[~np.isfinite(np.asarray(angles)).all(axis=1)] = np.nan
    times = np.arange(0.0, ts[-1] + 1e-9, 1.0 / c.processing.rate_hz)
    raw = pepper_angles(joints)
    processed = process_angles(
        raw=raw,
        timestamps=ts,
        clock=times,
        processing=c.processing,
        retarget=c.retarget,
        profile=profile,
    )
    feats = np.zeros((len(times), 26), np.float32) if audio is None else audio[: len(times)]
    arrays = {
        "angles": processed.angles,
        "angles01": processed.angles01,
        "mask": processed.mask,
        "audio": np.asarray(feats, np.float32),
        "times": times,
        "raw_angles": raw,
    }
    return _filmed(joints, ts, clip_id=clip_id, angles=arrays)


def clip_from_targets(
    angles01: np.ndarray,
    audio: np.ndarray,
    *,
    clip_id: str,
    profile: pepper.RobotProfile,
    rate_hz: float | None = None,
    raw01: np.ndarray | None = None,
) -> Clip:
    """A clip whose 100 Hz angles are exactly `angles01 (N, 11)` (NaN = unknown) with features
    `audio (N, F)`: for trainers, whose targets must be known exactly. Its poses are the angles'
    ideal forward kinematics at the same 100 Hz frames; its raw angles are `raw01 (N, 11)`
    (what the angles were made from, normalised) or, without it, the angles themselves."""
    ts = np.arange(len(angles01)) / (rate_hz or ProcessingConfig().rate_hz)
    angles = pepper.denormalise(np.asarray(angles01, np.float64), profile)
    raw = angles if raw01 is None else pepper.denormalise(np.asarray(raw01, np.float64), profile)
    joints = pepper.fk_coco17(np.nan_to_num(angles), model="ideal").astype(np.float32)
    joints[:, 13:] = np.nan  # no legs
    joints[~np.isfinite(angles).all(axis=1)] = np.nan
    arrays = {
        "angles": angles.astype(np.float32),
        "angles01": np.asarray(angles01, np.float32),
        "mask": np.isfinite(angles),
        "audio": np.asarray(audio, np.float32),
        "times": ts,
        "raw_angles": raw.astype(np.float32),
    }
    return _filmed(joints, ts, clip_id=clip_id, angles=arrays)


def synthetic_clip(
    seconds: float = 3.0, *, fps: float = 30.0, seed: int = 0, clip_id: str = "synthetic__c000"
) -> Clip:
    """A clean clip: smooth motion of every joint inside the limits (random phases, 0.3–0.8 Hz)."""
    rng = np.random.default_rng(seed)
    ts = np.arange(0, seconds, 1 / fps)
    prof = pepper.load_profile()
    mid, half = (prof.lower + prof.upper) / 2, (prof.upper - prof.lower) / 2
    phase = rng.uniform(0, 2 * np.pi, 11)
    freq = rng.uniform(0.3, 0.8, 11)
    angles = pepper.neutral_pose() + 0.3 * half * np.sin(2 * np.pi * freq * ts[:, None] + phase)
    angles = np.clip(angles, mid - 0.9 * half, mid + 0.9 * half)
    return clip_from_angles(angles, ts, clip_id=clip_id)


def write_dataset(
    out: Path,
    takes: Mapping[str, Sequence[Clip]],
    *,
    subjects: Mapping[str, str] | None = None,
    config: Config | None = None,
    in_turn: bool = True,
) -> Path:
    """A dataset folder holding `takes` (take id → its clips, ids `<take id>__cNNN`), each
    measured and judged by the real QC; subject = `subjects[take id]`, else the take id's part
    before the first "_". in_turn: the clips follow each other in their take (False: each keeps
    its start_s, e.g. two people's clips at the same time). Returns `out`."""
    from gesturebank.qc.checks import absolute_reasons
    from gesturebank.qc.metrics import clip_metrics

    c = config or Config()
    out = Path(out)
    profile = pepper.load_profile(c.robot.profile)
    measured = measure_digest(qc=c.qc, profile=c.robot.profile)
    for take_id, clips in takes.items():
        rows = []
        start = 0.0
        placed = []
        for clip in clips:
            if in_turn:
                clip = replace(clip, start_s=start)
            placed.append(clip)
            metrics = clip_metrics(clip, profile=profile, qc=c.qc)
            reasons = absolute_reasons(metrics, c.qc)
            rows.append(
                store.ClipRecord.of_clip(
                    clip, metrics=metrics.to_dict(), reasons=reasons, measured=measured
                )
            )
            start = max(start, clip.start_s + clip.duration_s)  # the take's end so far
        feats = np.concatenate([clip.audio for clip in clips]).astype(np.float64)
        record = store.TakeRecord(
            take_id=take_id,
            subject=(subjects or {}).get(take_id, take_id.split("_")[0]),
            source=f"{take_id}.mp4",
            config_digest=c.digest(*CONTENT_SECTIONS),
            detector="synthetic",
            lifter="synthetic",
            video_fps=30.0,
            seconds=start,
            visible_s=start,
            clips=tuple(rows),
            audio={
                "n": len(feats),
                "sum": feats.sum(axis=0).tolist(),
                "sumsq": np.square(feats).sum(axis=0).tolist(),
            },
        )
        store.write_take(out, record=record, clips=placed)
    refresh(out, c, videos_dir=out)
    return out
