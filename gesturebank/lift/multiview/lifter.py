"""`multiview`: the calibrated multi-camera lifter — several Pose2D + a CameraGroup → Pose3D.

Each view is converted to COCO-17, put on the reference camera's clock (known offsets, or
audio / motion synchronisation), the cameras' poses optionally refined from those keypoints
(`refine_cameras`: a bundle adjustment, `bundle`), then every joint of every frame is
triangulated with camera exclusion (`triangulate`). The result is in the calibration's world
frame, metres. Joints no two cameras agree on are NaN; confidence falls with the reprojection error:
`conf = mean 2D confidence of the cameras used × max_error / (max_error + error)` (½ at the
exclusion threshold for a perfectly confident detection).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gesturebank.camera_files import CameraGroup
from gesturebank.config import Config, MultiviewConfig
from gesturebank.errors import CalibrationError, InputError
from gesturebank.lift import LifterTraits, TakeViews
from gesturebank.lift.multiview.bundle import BundleReport, refine_cameras
from gesturebank.lift.multiview.refine import Refinement, refine, reprojection
from gesturebank.lift.multiview.robust import (
    TORSO,
    Cleaning,
    Views,
    facing,
    fix_swaps,
    make_consistent,
    relabel,
    unseen_face,
    untangle,
)
from gesturebank.lift.multiview.sync import align, estimate_offsets
from gesturebank.lift.multiview.triangulate import Triangulation, triangulate
from gesturebank.poses import Pose2D, Pose3D
from gesturebank.skeletons import COCO17

if TYPE_CHECKING:
    from gesturebank.audio.io import Audio

log = logging.getLogger(__name__)

# The joints the camera refinement adjusts: the body's, shoulders down. A detector places the
# nose and eyes differently from each side (on renders of test.bvh, BlazePose's nose lies 8 px
# left of the true one from -45° and 5 px right from +45°), which pulls the cameras round.
_BUNDLE_JOINTS = list(range(COCO17.index["left_shoulder"], len(COCO17.joints)))


@dataclass(frozen=True)
class MultiviewReport:
    """What the lifter did to one take.

    offsets_s (C,): camera clock minus reference clock; sync: method per camera;
    triangulation: per-point result on the reference timeline (T, 17); camera_names (C,);
    cleaning: swaps and gross outliers found; refinement: before/after of the take's fit
    (None when `refine` is off); labels (C, T, 17): the 2D joint of each camera that each
    joint was solved from (left/right swaps repaired; None: its own); bundle: the camera
    refinement's before/after (None when `refine_cameras` is off; the refined cameras are the
    Pose3D's).
    """

    offsets_s: np.ndarray
    sync: list[str]
    triangulation: Triangulation
    camera_names: list[str]
    cleaning: Cleaning = field(default_factory=Cleaning)
    refinement: Refinement | None = None
    labels: np.ndarray | None = None
    bundle: BundleReport | None = None

    def joint_table(self) -> list[tuple[str, float, float, float]]:
        """(joint, median error px, 90th percentile px, mean cameras used) per COCO-17 joint;
        NaN errors for joints never triangulated."""
        rows = []
        err, ncam = self.triangulation.error, self.triangulation.n_cameras
        for j, name in enumerate(COCO17.joints):
            e = err[:, j][np.isfinite(err[:, j])]
            med = float(np.median(e)) if e.size else float("nan")
            p90 = float(np.percentile(e, 90)) if e.size else float("nan")
            rows.append(
                (
                    name,
                    med,
                    p90,
                    float(ncam[:, j][np.isfinite(err[:, j])].mean()) if e.size else 0.0,
                )
            )
        return rows

    def camera_usage(self) -> dict[str, float]:
        """Fraction of triangulated joints each camera took part in."""
        ok = np.isfinite(self.triangulation.error)
        used = self.triangulation.used
        return {
            name: float(used[c][ok].mean()) if ok.any() else 0.0
            for c, name in enumerate(self.camera_names)
        }


class MultiviewLifter:
    """Triangulating lifter; its section is `multiview` (None: the defaults)."""

    name = "multiview"
    traits = LifterTraits(several_views=True, measured_depth=True)

    def __init__(self, *, multiview: MultiviewConfig | None = None) -> None:
        self.options = multiview or MultiviewConfig()

    @classmethod
    def from_config(cls, config: Config) -> MultiviewLifter:
        """The registry's factory (gesturebank.lift): the `multiview` section."""
        return cls(multiview=config.lifter.multiview)

    def lift(self, views: TakeViews) -> Pose3D:
        """One Pose2D per camera of `views.cameras` (same order), with the cameras' audio
        tracks when sync is by audio → Pose3D (T, 17, 3), metres, world frame, on the
        reference camera's timestamps."""
        return self.lift_with_report(views)[0]

    def lift_with_report(self, views: TakeViews) -> tuple[Pose3D, MultiviewReport]:
        cfg = self.options
        cams = views.cameras
        if cams is None:
            raise CalibrationError("multiview lifter: no cameras given (a calibration file)")
        poses = list(views.poses)
        if len(poses) < 2:
            raise InputError(f"multiview lifter: needs two or more views, got {len(poses)}")
        if len(poses) != len(cams):
            raise InputError(
                f"multiview lifter: {len(poses)} views but {len(cams)} cameras ({cams.names})"
            )
        if not 0 <= cfg.reference_camera < len(poses):
            raise InputError(
                f"multiview lifter: reference_camera {cfg.reference_camera} out of "
                f"range for {len(poses)} cameras"
            )
        for pose, cam in zip(poses, cams, strict=True):
            if tuple(pose.image_size) != cam.size:
                log.warning(
                    "camera %s: video is %dx%d, calibration %dx%d",
                    cam.name,
                    *pose.image_size,
                    *cam.size,
                )
        coco = [v.to_coco17() for v in poses]
        # Sync on the detector's own keypoints: more of them make a steadier motion curve.
        offsets, methods = self._offsets(poses, views.audios)
        times = coco[cfg.reference_camera].timestamps
        kp = align(coco, offsets, times=times)  # (C, T, 17, 3)
        bundle = None
        if cfg.refine_cameras:
            cams, bundle = refine_cameras(
                kp[:, :, _BUNDLE_JOINTS, :2],
                kp[:, :, _BUNDLE_JOINTS, 2],
                cameras=cams,
                fixed=cfg.reference_camera,
                min_confidence=cfg.bundle_min_confidence,
                max_frames=cfg.bundle_frames,
                loss_px=cfg.bundle_loss_px,
            )
        kp = _drop_unseen_face(kp, cams, cfg)
        obs = Views.of(kp, cams, min_confidence=cfg.min_confidence)
        swapped = fix_swaps(obs, max_error_px=cfg.max_error_px, max_width_dev=cfg.max_bone_dev)
        kp, obs = relabel(kp, swapped), obs.relabel(swapped)
        labels = relabel(np.broadcast_to(np.arange(kp.shape[2]), kp.shape[:3]), swapped)
        tri = triangulate(
            kp[..., :2],
            kp[..., 2],
            cameras=cams,
            min_confidence=cfg.min_confidence,
            max_error_px=cfg.max_error_px,
            min_cameras=cfg.min_cameras,
            max_combinations=cfg.max_combinations,
        )
        # A pair mirrored in 3D (two cameras agreeing on a swap): all its labels exchanged.
        crossed = untangle(tri.points)
        every = np.broadcast_to(crossed, swapped.shape)
        kp, obs, labels = relabel(kp, every), obs.relabel(every), relabel(labels, every)
        joints, error, used, mirrored, cleaning = make_consistent(
            relabel(tri.points[None], crossed[None])[0],
            relabel(tri.error[None], crossed[None])[0],
            used=relabel(tri.used, every),
            views=obs,
            max_error_px=cfg.max_error_px,
            max_bone_dev=cfg.max_bone_dev,
            max_jump=cfg.max_jump,
        )
        cleaning = replace(cleaning, swapped=int(swapped.sum()) // 2)  # a pair: two joints
        kp, obs, labels = relabel(kp, mirrored), obs.relabel(mirrored), relabel(labels, mirrored)
        # the error of what the take keeps (joints solved again from a pair included)
        error = reprojection(joints, obs, used=used)
        if cfg.reject_error_px is not None:
            bad = error > cfg.reject_error_px
            joints[bad], error[bad], used[:, bad] = np.nan, np.nan, False
        refinement = None
        if cfg.refine:
            joints, refinement = refine(
                joints,
                times,
                views=obs,
                used=used,
                max_error_px=cfg.max_error_px,
                smooth_accel_mps2=cfg.smooth_accel_mps2,
                bone_tolerance_m=cfg.bone_tolerance_m,
                chunk_frames=cfg.refine_chunk_frames,
            )
            error = reprojection(joints, obs, used=used)
        tri = Triangulation(points=joints, error=error, used=used)
        conf2d = np.where(used, np.nan_to_num(kp[..., 2]), 0.0).sum(0) / np.maximum(used.sum(0), 1)
        with np.errstate(invalid="ignore"):
            confidence = np.clip(conf2d * cfg.max_error_px / (cfg.max_error_px + error), 0, 1)
        confidence[~np.isfinite(error)] = np.nan
        report = MultiviewReport(
            offsets, methods, tri, cams.names, cleaning, refinement, labels, bundle
        )
        pose3d = Pose3D(
            joints.astype(np.float32),
            confidence.astype(np.float32),
            times,
            frame="world",
            units="m",
            meta={
                "lifter": self.name,
                "cameras": ",".join(cams.names),
                "offsets_s": ",".join(f"{o:.6f}" for o in offsets),
                "sync": ",".join(methods),
                "median_error_px": f"{_nanmedian(error):.3f}",
            },
            cameras=cams,
        )
        return pose3d, report

    def _offsets(
        self, views: list[Pose2D], audios: Sequence[Audio | None] | None
    ) -> tuple[np.ndarray, list[str]]:
        cfg = self.options
        if cfg.offsets_s is not None:
            if len(cfg.offsets_s) != len(views):
                raise InputError(
                    f"multiview lifter: {len(cfg.offsets_s)} offsets_s for {len(views)} cameras"
                )
            return np.asarray(cfg.offsets_s, np.float64), ["given"] * len(views)
        if cfg.sync == "none":
            return np.zeros(len(views)), ["none"] * len(views)
        offsets, methods, _ = estimate_offsets(
            views,
            audios,
            method=cfg.sync,
            reference=cfg.reference_camera,
            max_lag_s=cfg.max_offset_s,
        )
        return offsets, methods


def _drop_unseen_face(kp: np.ndarray, cams: CameraGroup, cfg: MultiviewConfig) -> np.ndarray:
    """`kp (C, T, 17, 3)` with confidence 0 for the nose and eyes of cameras that see the
    person's back (`robust.unseen_face`), judged on a first triangulation of the torso."""
    if cfg.back_view_cos is None:
        return kp
    tri = triangulate(
        kp[:, :, TORSO, :2],
        kp[:, :, TORSO, 2],
        cameras=cams,
        min_confidence=cfg.min_confidence,
        max_error_px=cfg.max_error_px,
        min_cameras=cfg.min_cameras,
        max_combinations=cfg.max_combinations,
    )
    back = facing(tri.points, np.stack([c.center for c in cams])) < cfg.back_view_cos
    drop = unseen_face(
        kp[..., 2], back, min_confidence=cfg.min_confidence, min_cameras=cfg.min_cameras
    )
    log.debug("face keypoints of a back view ignored: %d", int(drop.sum()))
    out = kp.copy()
    out[..., 2][drop] = 0.0
    return out


def _nanmedian(values: np.ndarray) -> float:
    finite = values[np.isfinite(values)]
    return float(np.median(finite)) if finite.size else float("nan")


def match_cameras(
    cameras: CameraGroup, videos: Sequence[str | os.PathLike[str]]
) -> tuple[CameraGroup, list[Path]]:
    """The calibrated cameras that have a video, and those videos in camera order.

    By name: a camera called 'cam01' takes the video whose stem is 'cam01' (else starts with
    it); any two or more of the calibrated cameras may be used (a broken camera left out).
    Else, when the counts agree, by sorted file name. CalibrationError when neither works.
    """
    paths = sorted(Path(v) for v in videos)
    names, matched = [], []
    for cam in cameras:
        hits = [p for p in paths if p.stem == cam.name] or [
            p for p in paths if p.stem.startswith(cam.name)
        ]
        if len(hits) == 1:
            names.append(cam.name)
            matched.append(hits[0])
    if len(matched) >= 2 and len(set(matched)) == len(matched) == len(paths):
        return cameras.subset(names), matched
    if len(paths) != len(cameras):
        raise CalibrationError(
            f"{len(paths)} videos for {len(cameras)} calibrated cameras ({cameras.names}) and "
            "the names do not match"
        )
    log.warning("videos matched to cameras %s by sorted file name", cameras.names)
    return cameras, paths


def match_videos(cameras: CameraGroup, videos: Sequence[str | os.PathLike[str]]) -> list[Path]:
    """The videos in the order of all the `cameras` (see `match_cameras`); CalibrationError
    when some camera has no video."""
    used, ordered = match_cameras(cameras, videos)
    if len(used) != len(cameras):
        raise CalibrationError(
            f"{len(ordered)} videos for {len(cameras)} calibrated cameras ({cameras.names})"
        )
    return ordered
