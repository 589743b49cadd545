"""A take's views: what its clips are cut from, one per person of a single-camera take (the main
speaker, or everybody with build.people = "all"), one triangulated view of a multi-camera take, or
a motion-capture take's front view (docs/architecture.md "Data flow")."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from gesturebank.audio.io import Audio
from gesturebank.config import Config
from gesturebank.datasets.head import FaceHead, rig_head
from gesturebank.datasets.takes import Take
from gesturebank.errors import InputError
from gesturebank.geometry import Camera
from gesturebank.lift.clip_confidence import lifter_traits
from gesturebank.mocap import MOCAP
from gesturebank.mocap.front_view import front_view
from gesturebank.poses import Pose2D, Pose3D
from gesturebank.qc.usable import still_spiking
from gesturebank.repair import repair_pose2d, repair_pose3d, validity
from gesturebank.repair.snaps import others_of, unsnap
from gesturebank.skeletons import COCO17, get_skeleton, to_coco17

if TYPE_CHECKING:
    from gesturebank.extract.cache import DetectionCache
    from gesturebank.extract.head_pose import HeadPoses
    from gesturebank.extract.tracking import Tracked, TrackReport
    from gesturebank.poses import MultiPose2D


@dataclass(frozen=True)
class TakeView:
    """What the clips are cut from: the main speaker on the take's (reference) frames (of a
    multi-camera take, pose2d is the reference camera's, drawn but not judged: `multi_view`).

    valid / repaired: (T, 17) COCO-17 bools; speaker: (T,) the person's track id (the main
    speaker's, or one person's with build.people = "all"); role: (T,) int8 their role code
    (clip.ROLES); lift(a, b): the 3D pose of frames [a, b) (lifted per clip for one camera,
    sliced for several); face: their head from the face mesh in the camera's axes, or None;
    camera: the calibrated camera that saw it (multi-camera takes)."""

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
    cached: bool | None = None  # detections from the cache (every camera's); None: not cached
    face: FaceHead | None = None
    camera: Camera | None = None


def lifter_name(take: Take, config: Config) -> str:
    """The lifter of `take`: `lifter.name`, except that a multi-camera take is triangulated."""
    if take.mocap:
        return MOCAP
    return "multiview" if take.multi_camera else config.lifter.name


def _tracking_json(report: TrackReport) -> dict[str, Any]:
    """The main-speaker report for the take record, without its per-frame arrays (the clips
    hold what matters of them; a long take would make the record large)."""
    data = report.to_json_dict()
    return {k: v for k, v in data.items() if k not in ("main_ids", "n_people")}


def _coco17_mask(mask: np.ndarray, skeleton: str) -> np.ndarray:
    """`(T, K)` bools of `skeleton` → `(T, 17)` COCO-17 (joints it lacks: False)."""
    out = get_skeleton(skeleton).convert(mask[..., None].astype(np.float32), COCO17)[..., 0]
    return np.nan_to_num(out, nan=0.0) > 0.5


def single_views(take: Take, *, config: Config, chunks: DetectionCache | None) -> list[TakeView]:
    """One camera: the main speaker's view, or with build.people = "all" one view per tracked
    person (by track id)."""
    from gesturebank.app.extract import extract_take
    from gesturebank.extract.identity import gather
    from gesturebank.lift import LIFTERS

    if lifter_traits(config.lifter.name).several_views:  # known before the slow extraction
        raise InputError(
            f"{take.video}: the {config.lifter.name} lifter needs a multi-camera take (a folder "
            "with a calibration file and two or more videos)"
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
            gather(ext.multi, ids, track_id=track),
            others_of(ext.multi, ids, track=track),
            config=config.repair,
        )
        pose, report = repair_pose2d(own, config=config.repair)
        valid = _coco17_mask(
            validity(pose, visible_confidence=config.repair.visible_confidence), pose.skeleton
        )
        xy = to_coco17(pose.keypoints, pose.skeleton)[..., :2]
        valid &= ~still_spiking(xy, valid, max_spike=config.repair.max_spike)
        views.append(
            TakeView(
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
                cached=ext.info.cache_hit,
                tracking={
                    **_tracking_json(ext.tracked.report),
                    "mouth_seconds": ext.info.mouth_seconds,
                    "people": people_summary(ext.multi, ext.tracked),
                },
                preview=ext.preview,
                face=face_head(ext.heads, track, image_size=pose.image_size, config=config),
            )
        )
    return views


def face_head(
    heads: HeadPoses | None,
    track: np.ndarray,
    *,
    image_size: tuple[int, int],
    config: Config,
    camera: Camera | None = None,
) -> FaceHead | None:
    """The head of the person given per frame by `track (T,)` from the face mesh, in the
    camera's axes (`extract.head_pose.on_ray`: the calibrated `camera`'s intrinsics, else a
    pinhole of `fitted.fov_deg`); None without face measurements."""
    from gesturebank.extract.head_pose import on_ray
    from gesturebank.lift.fitted import pinhole

    if heads is None:
        return None
    axes, centre, residual = heads.of(track)
    focal, principal, _ = pinhole(
        np.zeros((0, 2)), image_size, camera=camera, fov_deg=config.lifter.fitted.fov_deg
    )
    if camera is not None:
        centre = camera.undistort_points(centre)
    return FaceHead(on_ray(axes, centre, focal=focal, principal=principal), residual)


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


def multi_view(take: Take, *, config: Config, chunks: DetectionCache | None) -> TakeView:
    """A multi-camera take: every camera detected and repaired, triangulated by the multi-view
    lifter. The reference camera's clock, shots and speaker stand for the take, its 2D pose is
    kept to be drawn; the QC judges the 3D as every camera sees it (the cameras travel in the
    3D pose's `cameras`, set by the lifter), not the reference camera's 2D. The head from the
    face is every camera's that found it, averaged (`datasets.head.rig_head`). The
    audio is a .wav beside the videos, else the camera track with the most energy, moved onto
    the reference clock by the camera offsets the lifter used."""
    from gesturebank.app.extract import extract_take
    from gesturebank.audio.io import read_audio
    from gesturebank.camera_files import load_cameras
    from gesturebank.lift import LIFTERS, TakeViews
    from gesturebank.lift.multiview.lifter import MultiviewLifter, match_cameras

    assert take.calibration is not None
    # any subset of the calibrated cameras, by name (a broken camera left out)
    cameras, videos = match_cameras(load_cameras(take.calibration), take.videos)
    exts = [extract_take(v, config, chunks=chunks) for v in videos]
    repaired = [repair_pose2d(e.tracked.pose, config=config.repair) for e in exts]
    poses = [pose for pose, _ in repaired]
    audios = [e.audio for e in exts]
    lifter = LIFTERS.create(lifter_name(take, config), config)
    assert isinstance(lifter, MultiviewLifter)  # the audio choice below needs its camera offsets
    pose3d, report = lifter.lift_with_report(TakeViews(tuple(poses), cameras, tuple(audios)))
    pose3d, report3d = repair_pose3d(pose3d, config=config.repair)
    ref = config.lifter.multiview.reference_camera
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
    return TakeView(
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
        cached=None if None in (hits := [x.info.cache_hit for x in exts]) else all(hits),
        tracking=_tracking_json(e.tracked.report),
        preview=e.preview,
        face=rig_head(
            [
                face_head(
                    x.heads,
                    x.tracked.report.main_ids,
                    image_size=pose.image_size,
                    config=config,
                    camera=camera,
                )
                for x, pose, camera in zip(exts, poses, cameras, strict=True)
            ],
            times=[pose.timestamps for pose in poses],
            offsets_s=report.offsets_s,
            cameras=list(cameras),
            reference=ref,
            max_residual=config.retarget.head_max_fit_residual,
        ),
        camera=cameras[ref],
    )


def mocap_view(take: Take, config: Config) -> TakeView:
    """A motion-capture take: the BVH's forward kinematics is the 3D pose (no detector, no
    lifter), one speaker, one shot; its audio starts with the first frame."""
    import time

    from gesturebank.audio.io import read_audio
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
    pose2d = front_view(pose3d)
    t = len(pose3d)
    return TakeView(
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
