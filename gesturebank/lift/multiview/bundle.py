"""Keypoint bundle adjustment: a rig's camera poses refined from the person's own joints.

A calibration drifts (a tripod knocked, a rough board calibration); the person in every frame is
a calibration object too. Each joint of each chosen frame is one 3D point, seen by the cameras
whose 2D keypoint there is confident. The points are triangulated with the given cameras, then
pycolmap (COLMAP's Ceres bundle adjuster) moves the cameras' poses and the points together to
minimise the robust (Cauchy) reprojection error. Fixed: the intrinsics of every camera (the
distortion is taken out beforehand, so each camera is a pinhole) and the pose of one camera
(`fixed`, the reference). That leaves one freedom unobserved, the scale about the fixed
camera; it is set back so that the mean distance from the fixed camera to the others stays the
calibration's.

Static cameras: each camera is one COLMAP image (its own trivial rig and frame) holding every
observation of the chosen frames, so the solver sees C poses and one point per joint per frame.

`camera_errors` compares two calibrations of the same rig after a similarity alignment of the
cameras' poses (the gauge a bundle adjustment leaves): rotation ° and position per camera.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from gesturebank.camera_files import CameraGroup
from gesturebank.errors import InputError
from gesturebank.geometry import Camera, similarity
from gesturebank.lift.multiview.triangulate import dlt, reprojection_errors

log = logging.getLogger(__name__)

_MIN_FRAMES = 3  # fewer frames: the joints of one pose barely constrain a camera's rotation
_MIN_OBSERVATIONS = 20  # per camera: each pose has 6 unknowns, each observation gives 2
_MAX_ITERATIONS = 500  # a camera orbiting the person is a shallow valley: 100 stop short


@dataclass(frozen=True)
class BundleReport:
    """What `refine_cameras` did: frames and points adjusted, the observations used, the median
    reprojection error (undistorted px) before and after, and the solver's termination
    ('CONVERGENCE', 'NO_CONVERGENCE', ...)."""

    frames: int
    points: int
    observations: int
    error_before_px: float
    error_after_px: float
    termination: str


def select_frames(usable: np.ndarray, *, max_frames: int) -> np.ndarray:
    """Indices (sorted) of up to `max_frames` frames from `usable (C, T, J)` (confident
    observations of points that two or more cameras see): among the frames with at least the
    median count of them (the confident ones), evenly spaced over the take (well spread)."""
    counts = usable.sum(axis=(0, 2))
    seen = np.flatnonzero(counts > 0)
    if seen.size == 0:
        return seen
    candidates = seen[counts[seen] >= np.median(counts[seen])]
    picks = np.linspace(0, candidates.size - 1, min(max_frames, candidates.size))
    return candidates[np.unique(np.round(picks).astype(int))]


def refine_cameras(
    pixels: np.ndarray,
    confidence: np.ndarray,
    *,
    cameras: CameraGroup,
    fixed: int,
    min_confidence: float,
    max_frames: int,
    loss_px: float,
) -> tuple[CameraGroup, BundleReport]:
    """The cameras with refined poses, and the report (module docstring).

    pixels (C, T, J, 2) raw (distorted) keypoints on one clock, NaN = not seen; confidence
    (C, T, J); fixed: index of the camera whose pose is held; min_confidence, max_frames,
    loss_px: the `multiview` fields bundle_min_confidence, bundle_frames, bundle_loss_px.
    InputError (one line) when the keypoints cannot constrain every camera.
    """
    import pycolmap  # the only user: a take without camera refinement never loads it

    px = np.asarray(pixels, np.float64)
    conf = np.nan_to_num(np.asarray(confidence, np.float64))
    C = len(cameras)
    if px.ndim != 4 or px.shape[0] != C or px.shape[-1] != 2 or conf.shape != px.shape[:-1]:
        raise InputError(
            f"camera refinement: need pixels (C={C}, T, J, 2) and confidence (C, T, J), got "
            f"{px.shape} and {conf.shape}"
        )
    if C < 2:
        raise InputError(f"camera refinement: needs two or more cameras, got {C}")
    if not 0 <= fixed < C:
        raise InputError(f"camera refinement: fixed camera {fixed} out of range for {C} cameras")

    normalised = cameras.undistort_points(px, normalised=True)  # (C, T, J, 2)
    confident = np.isfinite(normalised).all(-1) & (conf >= min_confidence)
    usable = confident & (confident.sum(axis=0) >= 2)
    frames = select_frames(usable, max_frames=max_frames)
    if frames.size < _MIN_FRAMES:
        raise InputError(
            f"camera refinement: {frames.size} frames with joints two cameras see at "
            f"confidence ≥ {min_confidence:g}, needs at least {_MIN_FRAMES}"
        )
    obs_xy = normalised[:, frames].reshape(C, -1, 2)  # (C, N, 2), N = frames × joints
    weights = np.where(usable[:, frames].reshape(C, -1), conf[:, frames].reshape(C, -1), 0.0)
    extrinsics = np.stack([c.extrinsics for c in cameras])
    focals = np.stack([np.diag(c.K)[:2] for c in cameras])
    points = dlt(obs_xy, extrinsics, weights=weights)
    errors = reprojection_errors(points, obs_xy, extrinsics=extrinsics, focals=focals)
    keep = np.isfinite(points).all(-1) & ~np.isinf(np.where(weights > 0, errors, 0)).any(0)
    points, obs_xy, weights = points[keep], obs_xy[:, keep], weights[:, keep]
    seen = weights > 0
    per_camera = seen.sum(axis=1)
    if per_camera.min() < _MIN_OBSERVATIONS:
        worst = int(per_camera.argmin())
        raise InputError(
            f"camera refinement: camera {cameras[worst].name!r} sees {per_camera[worst]} "
            f"confident joints shared with another camera, needs at least {_MIN_OBSERVATIONS}"
        )
    before = _median_error(points, obs_xy, seen, extrinsics, focals)

    rec = pycolmap.Reconstruction()
    for c, cam in enumerate(cameras):
        fx, fy, cx, cy = cam.K[0, 0], cam.K[1, 1], cam.K[0, 2], cam.K[1, 2]
        rec.add_camera_with_trivial_rig(
            pycolmap.Camera(
                model="PINHOLE",
                width=cam.size[0],
                height=cam.size[1],
                params=[fx, fy, cx, cy],
                camera_id=c + 1,
            )
        )
        # the undistorted observations in this pinhole's pixels (no skew: K's is dropped)
        ideal = obs_xy[c] * [fx, fy] + [cx, cy]
        rec.add_image_with_trivial_frame(
            pycolmap.Image(
                name=cam.name, keypoints=np.nan_to_num(ideal), camera_id=c + 1, image_id=c + 1
            ),
            pycolmap.Rigid3d(cam.extrinsics),
        )
    for n in range(len(points)):
        track = pycolmap.Track()
        for image in np.flatnonzero(seen[:, n]).tolist():
            track.add_element(image + 1, n)  # image ids start at 1; keypoint n of each
        rec.add_point3D(points[n], track)

    config = pycolmap.BundleAdjustmentConfig()
    for c in range(C):
        config.add_image(c + 1)
        config.set_constant_cam_intrinsics(c + 1)
    config.set_constant_rig_from_world_pose(fixed + 1)  # trivial frames: frame id = image id
    options = pycolmap.BundleAdjustmentOptions()
    options.refine_focal_length = False
    options.refine_principal_point = False
    options.refine_extra_params = False
    options.print_summary = False
    options.ceres.loss_function_type = pycolmap.LossFunctionType.CAUCHY
    options.ceres.loss_function_scale = loss_px
    options.ceres.solver_options.max_num_iterations = _MAX_ITERATIONS
    # Ceres logs every rejected step (a singular damped system along the free scale) as a
    # warning; the solver recovers by itself, so only errors are let through.
    level = pycolmap.logging.minloglevel
    pycolmap.logging.minloglevel = pycolmap.logging.ERROR.value
    try:
        summary = pycolmap.create_default_bundle_adjuster(options, config, rec).solve()
    finally:
        pycolmap.logging.minloglevel = level

    adjusted = np.stack([rec.image(c + 1).cam_from_world().matrix() for c in range(C)])
    solved = np.stack([rec.point3D(i).xyz for i in sorted(rec.point3D_ids())])
    # The scale about the fixed camera is free: set it back to the calibration's baseline.
    centre = cameras[fixed].center
    old = np.stack([c.center for c in cameras])
    new = np.stack([-R.T @ t for R, t in zip(adjusted[:, :, :3], adjusted[:, :, 3], strict=True)])
    others = np.arange(C) != fixed
    scale = np.linalg.norm(old[others] - centre, axis=1).mean() / max(
        np.linalg.norm(new[others] - centre, axis=1).mean(), 1e-12
    )
    refined = []
    for c, cam in enumerate(cameras):
        if c == fixed:
            refined.append(cam)  # exactly the given pose, whatever the solver's round-off
            continue
        R = adjusted[c, :, :3]
        moved = centre + scale * (new[c] - centre)
        refined.append(Camera(name=cam.name, size=cam.size, K=cam.K, dist=cam.dist, R=R,
                              t=-R @ moved))  # fmt: skip
    group = CameraGroup(refined)
    solved = centre + scale * (solved - centre)
    after_extr = np.stack([c.extrinsics for c in group])
    report = BundleReport(
        frames=int(frames.size),
        points=len(points),
        observations=int(seen.sum()),
        error_before_px=before,
        error_after_px=_median_error(solved, obs_xy, seen, after_extr, focals),
        termination=summary.termination_type.name,
    )
    log.info("camera refinement: %s", report)
    return group, report


def _median_error(
    points: np.ndarray,
    normalised: np.ndarray,
    seen: np.ndarray,
    extrinsics: np.ndarray,
    focals: np.ndarray,
) -> float:
    errors = reprojection_errors(points, normalised, extrinsics=extrinsics, focals=focals)[seen]
    errors = errors[np.isfinite(errors)]
    return float(np.median(errors)) if errors.size else float("nan")


def camera_errors(cameras: CameraGroup, truth: CameraGroup) -> tuple[np.ndarray, np.ndarray]:
    """Rotation error (degrees) and position error (world units) of each camera (C,) after the
    similarity that best maps the poses of `cameras` onto those of `truth` (Umeyama over each
    camera's centre and the tips of its three axes drawn as long as the mean distance between
    the true centres, so the orientations count as much as the positions); two or more
    cameras, in the same order."""
    if len(cameras) != len(truth) or len(cameras) < 2:
        raise InputError(
            f"camera errors: need the same two or more cameras, got {len(cameras)} and {len(truth)}"
        )
    true_centres = np.stack([c.center for c in truth])
    reach = np.linalg.norm(true_centres[:, None] - true_centres[None], axis=-1).sum() / (
        len(truth) * (len(truth) - 1)
    )

    def frusta(group: CameraGroup, length: float) -> np.ndarray:
        # a camera's axes in the world are the rows of R
        return np.concatenate([np.vstack([c.center, c.center + length * c.R]) for c in group])

    centres = np.stack([c.center for c in cameras])
    own_reach = np.linalg.norm(centres[:, None] - centres[None], axis=-1).sum() / (
        len(cameras) * (len(cameras) - 1)
    )
    scale, rot, shift = similarity(frusta(cameras, own_reach), frusta(truth, reach))
    aligned = centres @ (scale * rot).T + shift
    positions = np.linalg.norm(aligned - true_centres, axis=1)
    rotations = []
    for cam, true in zip(cameras, truth, strict=True):
        # world' = s·rot·world + shift, so the aligned camera's rotation is cam.R @ rot.T
        delta = (cam.R @ rot.T) @ true.R.T
        cos = np.clip((np.trace(delta) - 1.0) / 2.0, -1.0, 1.0)
        rotations.append(np.degrees(np.arccos(cos)))
    return np.asarray(rotations), positions
