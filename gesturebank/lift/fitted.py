"""`fitted`: a constant-length upper-body skeleton fitted to the 2D keypoints under perspective.

Per take, a kinematic skeleton of 12 bones (half shoulder width, spine, half hip width, upper
arms, forearms, neck → nose, nose → eyes, eyes → ears) with one length each, estimated over the
take from the depth prior (the median of its bone lengths, left and right averaged). Per frame,
the pose — the neck's position in the camera frame and each bone's direction — is fitted by
least squares to:

- the detector's 2D keypoints under a pinhole camera (the calibration's intrinsics and lens
  distortion when one is given, else a focal length from `fov_deg`), weighted by √confidence;
- the prior's bone directions: BlazePose's world landmarks when the detector gave them, else
  the `geometric` lifter's assumptions. The prior is seen along the ray through the person (its
  orientation is turned from the optical axis onto that ray). It settles the depth-sign
  ambiguity of each bone (a bone tilted towards or away from the camera looks the same); the
  image settles the rest;
- a temporal smoothness term: the acceleration of the neck and of every bone vector.

One `scipy.optimize.least_squares` per chunk of frames (`chunk_frames`, overlapping by a few
frames so chunks join smoothly), with an analytic sparse Jacobian: no loop over frames.

Output: Pose3D in the camera frame (OpenCV axes: x right, y down, z forward — right-handed),
metres as far as the prior's lengths are; knees and ankles NaN; a joint whose 2D keypoint is
missing is NaN. A joint whose bone ends up more than `flag_angle_deg` from the prior's direction
is flagged (`FittedReport`, `lift_with_report`) and its confidence multiplied by
`flag_confidence`, as the geometric lifter flags what breaks its assumptions.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from gesturebank.config import Config, FittedConfig, GeometricConfig
from gesturebank.geometry import Camera
from gesturebank.lift import TakeViews
from gesturebank.lift.geometric import GeometricLifter, chain_confidence
from gesturebank.lift.skeleton_fit import (
    N_BONES,
    N_JOINTS,
    FitProblem,
    bone_vectors,
    ray_rotations,
    second_difference,
    skeleton_joints,
    solve,
    take_lengths,
)
from gesturebank.poses import Pose2D, Pose3D
from gesturebank.skeletons import COCO17

_MARGIN = 8  # frames shared by neighbouring chunks, so their smoothness terms meet
# The joints each bone ends at: flagged when the bone disagrees with the prior.
_CHILD = [(5, 6), (11, 12), (11, 12), (7,), (9,), (8,), (10,), (0,), (1,), (2,), (3,), (4,)]


@dataclass(frozen=True, eq=False)
class FittedReport:
    """What the fit did to one take.

    disagree: (T, 17) bool, the joint's bone is more than `flag_angle_deg` from the prior's.
    reprojection_px: (T, 17) distance between the fitted joint's projection and its 2D keypoint,
        pixels (NaN where either is missing).
    bone_lengths: bone name → length used over the take (output units).
    prior: "blazepose-world" or "geometric"; focal_px: the focal length used.
    """

    disagree: np.ndarray
    reprojection_px: np.ndarray
    bone_lengths: dict[str, float]
    prior: str
    focal_px: float

    @property
    def flagged_frames(self) -> np.ndarray:
        """(T,) bool: frames with at least one flagged joint."""
        return np.asarray(self.disagree.any(axis=1))


def pinhole(
    xy: np.ndarray, image_size: tuple[int, int], *, camera: Camera | None, fov_deg: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Focal (2,), principal point (2,) and keypoints xy (..., 2) as ideal pinhole pixels: the
    calibrated `camera`'s (undistorted), else a focal from `fov_deg` across the longer side."""
    if camera is not None:
        K = camera.K
        return np.diag(K)[:2].copy(), K[:2, 2].copy(), camera.undistort_points(xy)
    f = 0.5 * max(image_size) / np.tan(np.deg2rad(fov_deg) / 2)
    return np.array([f, f]), np.asarray(image_size, np.float64) / 2, xy


# --------------------------------------------------------------------------------------------------
# The lifter


class FittedLifter:
    name = "fitted"

    def __init__(
        self, *, fitted: FittedConfig | None = None, geometric: GeometricConfig | None = None
    ) -> None:
        """fitted: the lifter's section; geometric: the prior's when the detector gave no world
        landmarks (None: their defaults)."""
        self.options = fitted or FittedConfig()
        self.geometric = geometric or GeometricConfig()

    @classmethod
    def from_config(cls, config: Config) -> FittedLifter:
        """The registry's factory (gesturebank.lift): the `fitted` and `geometric` sections."""
        return cls(fitted=config.lifter.fitted, geometric=config.lifter.geometric)

    def lift(self, views: TakeViews) -> Pose3D:
        """One view of any skeleton → Pose3D (T, 17, 3), camera frame (module docstring). With
        `views.cameras` (that one camera), its intrinsics and distortion; else `fov_deg`."""
        return self.lift_with_report(views)[0]

    def lift_with_report(self, views: TakeViews) -> tuple[Pose3D, FittedReport]:
        pose2d = views.single(self.name)
        calibrated = views.single_camera(self.name)
        cfg = self.options
        coco = pose2d.to_coco17()
        kp = coco.keypoints[:, :N_JOINTS].astype(np.float64)
        T = len(kp)
        focal, center, observed = self._camera(kp[..., :2], pose2d.image_size, calibrated)
        conf = np.nan_to_num(kp[..., 2], nan=1.0)  # a keypoint without a score is trusted
        seen = np.isfinite(observed).all(axis=-1)
        weight = np.where(seen & (conf >= cfg.min_confidence), np.sqrt(conf), 0.0)
        prior_joints, prior_name = self._prior(pose2d)
        prior_bones = bone_vectors(prior_joints)
        lengths = take_lengths(prior_bones)
        neck_px = observed[:, 5:7].mean(axis=1)
        usable = np.flatnonzero((weight[:, 5:7] > 0).all(axis=1) & np.isfinite(lengths).all())

        joints = np.full((T, len(COCO17), 3), np.nan)
        disagree = np.zeros((T, len(COCO17)), bool)
        if usable.size:
            rot = ray_rotations(neck_px[usable], focal, center=center)
            prior = np.einsum("tij,tbj->tbi", rot, prior_bones[usable])
            prior /= np.linalg.norm(prior, axis=-1, keepdims=True)
            has_prior = np.isfinite(prior).all(axis=-1)
            typical = np.nanmedian(np.where(has_prior[..., None], prior, np.nan), axis=0)
            typical = np.where(np.isfinite(typical), typical, [0.0, 0.0, -1.0])  # bone to camera
            prior = np.where(has_prior[..., None], prior, typical / np.linalg.norm(typical))
            x0 = self._start(observed[usable], neck_px[usable], prior, lengths, focal, center)
            arrays = {
                "observed": np.nan_to_num(observed[usable]),
                "weight": weight[usable],
                "prior": prior,
                "prior_weight": np.where(has_prior, cfg.prior_weight, 0.0),
            }
            times = pose2d.timestamps[usable]
            camera = {"focal": focal, "center": center}
            lengths = self._lengths(arrays, camera, lengths=lengths, times=times, x0=x0)
            fitted = self._fit(arrays, camera, lengths=lengths, times=times, x0=x0)
            u = fitted[:, 1:] / np.linalg.norm(fitted[:, 1:], axis=-1, keepdims=True)
            joints[usable, :N_JOINTS] = skeleton_joints(fitted[:, 0], lengths[:, None] * u)
            off = np.sum(u * prior, axis=-1) < np.cos(np.deg2rad(cfg.flag_angle_deg))
            off &= has_prior
            for b, children in enumerate(_CHILD):
                disagree[np.ix_(usable, np.asarray(children))] |= off[:, b, None]
        for side in ("left", "right"):  # a flagged elbow taints its wrist
            disagree[:, COCO17.index[f"{side}_wrist"]] |= disagree[:, COCO17.index[f"{side}_elbow"]]

        missing = ~np.isfinite(joints).all(axis=-1)
        missing[:, :N_JOINTS] |= ~seen
        joints[missing] = np.nan
        disagree &= ~missing
        full_conf = np.full((T, len(COCO17)), np.nan)
        full_conf[:, :N_JOINTS] = np.where(seen, conf, np.nan)
        confidence = chain_confidence(full_conf)
        confidence = np.where(disagree, confidence * cfg.flag_confidence, confidence)
        confidence = np.where(missing, np.nan, confidence)
        with np.errstate(invalid="ignore", divide="ignore"):
            proj = focal * joints[:, :N_JOINTS, :2] / joints[:, :N_JOINTS, 2:] + center
        reprojection = np.full((T, len(COCO17)), np.nan)
        reprojection[:, :N_JOINTS] = np.linalg.norm(proj - observed, axis=-1)
        report = FittedReport(
            disagree=disagree,
            reprojection_px=reprojection,
            bone_lengths={
                f"bone{b}-{COCO17.joints[c[0]]}": float(v)
                for b, (c, v) in enumerate(zip(_CHILD, lengths, strict=True))
            },
            prior=prior_name,
            focal_px=float(focal.mean()),
        )
        pose = Pose3D(
            joints.astype(np.float32),
            confidence.astype(np.float32),
            pose2d.timestamps,
            frame="camera",
            units="m",
            meta={
                "lifter": self.name,
                "prior": prior_name,
                "focal_px": f"{focal.mean():.1f}",
                "flagged_frames": str(int(report.flagged_frames.sum())),
            },
        )
        return pose, report

    def _camera(
        self, xy: np.ndarray, image_size: tuple[int, int], camera: Camera | None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return pinhole(xy, image_size, camera=camera, fov_deg=self.options.fov_deg)

    def _prior(self, pose2d: Pose2D) -> tuple[np.ndarray, str]:
        """Prior joints (T, 17, 3) in camera axes, metres: BlazePose world, else geometric."""
        if pose2d.world is not None:
            return pose2d.to_coco17().world.astype(np.float64), "blazepose-world"  # type: ignore[union-attr]
        metric = self.geometric.model_copy(update={"units": "m"})
        geo = GeometricLifter(geometric=metric).lift(TakeViews.of(pose2d)).joints
        geo = geo.astype(np.float64)
        return geo * np.array([1.0, -1.0, -1.0]), "geometric"  # image-ortho → camera axes

    @staticmethod
    def _start(
        observed: np.ndarray,
        neck_px: np.ndarray,
        prior: np.ndarray,
        lengths: np.ndarray,
        focal: np.ndarray,
        center: np.ndarray,
    ) -> np.ndarray:
        """(T, 13, 3) start: the prior's directions, the neck on its ray at the take's typical
        depth (the shoulder width in pixels against its length)."""
        width_px = np.linalg.norm(observed[:, 5] - observed[:, 6], axis=-1)
        depth = float(np.nanmedian(focal.mean() * 2 * lengths[0] / width_px))
        x0 = np.empty((len(observed), N_JOINTS, 3))
        x0[:, 0, :2] = (neck_px - center) / focal * depth
        x0[:, 0, 2] = depth
        x0[:, 1:] = prior
        return x0

    def _problem(
        self,
        arrays: dict[str, np.ndarray],
        camera: dict[str, np.ndarray],
        frames: np.ndarray,
        *,
        lengths: np.ndarray,
        times: np.ndarray,
    ) -> FitProblem:
        """The problem over `frames` (indices into the usable frames), lengths fixed."""
        return FitProblem(
            observed=arrays["observed"][frames],
            weight=arrays["weight"][frames],
            prior=arrays["prior"][frames],
            prior_weight=arrays["prior_weight"][frames],
            lengths=lengths,
            focal=camera["focal"],
            center=camera["center"],
            accel=second_difference(times[frames]),
            smoothness=self.options.smoothness,
        )

    def _lengths(
        self,
        arrays: dict[str, np.ndarray],
        camera: dict[str, np.ndarray],
        *,
        lengths: np.ndarray,
        times: np.ndarray,
        x0: np.ndarray,
    ) -> np.ndarray:
        """(12,) the take's bone lengths: fitted with the poses of up to `chunk_frames` frames
        spread over the take, starting from (and held near) the prior's lengths."""
        if self.options.length_weight is None:
            return lengths
        pick = np.unique(np.linspace(0, len(x0) - 1, min(len(x0), self.options.chunk_frames)))
        pick = pick.astype(int)
        problem = self._problem(arrays, camera, pick, lengths=lengths, times=times)
        problem = replace(problem, length_weight=self.options.length_weight)
        start = np.concatenate([x0[pick].ravel(), lengths])
        return solve(problem, start)[-N_BONES:]

    def _fit(
        self,
        arrays: dict[str, np.ndarray],
        camera: dict[str, np.ndarray],
        *,
        lengths: np.ndarray,
        times: np.ndarray,
        x0: np.ndarray,
    ) -> np.ndarray:
        """(T, 13, 3) poses: chunks of `chunk_frames` (overlapping by _MARGIN), joined."""
        n, step = len(x0), self.options.chunk_frames
        out = np.empty_like(x0)
        for start in range(0, n, step):
            lo, hi = max(0, start - _MARGIN), min(n, start + step + _MARGIN)
            frames = np.arange(lo, hi)
            problem = self._problem(arrays, camera, frames, lengths=lengths, times=times)
            fit = solve(problem, x0[lo:hi].ravel()).reshape(hi - lo, N_JOINTS, 3)
            out[start : start + step] = fit[start - lo : start - lo + step]
        return out
