"""`resolved`: a skeleton lifted from one view with each bone's depth sign decoded over the take.

The 2D fixes every joint up to one choice per bone, towards or away from the camera
(gesturebank.lift.depth_sign). This lifter makes that choice over the whole take instead of per
frame by a fixed assumption:

1. Camera and scale. Pinhole intrinsics from the view's calibration, else the `fitted` section's
   `fov_deg`. The neck (mid-shoulders) lies on its ray at a depth from the spine's 2D length
   (running median over `depth_window_s`) against its assumed length; that length follows from
   the geometric section's `shoulder_width_m` and the take's spine-to-shoulder ratio.
2. Bone lengths, per take: a high percentile (`length_percentile`) of each bone's 2D length scaled
   to metres at the neck's depth (a bone is seen at its full length whenever it crosses the image
   plane), left and right averaged.
3. Torso: the shoulder line (left shoulder nearer or farther) and the nose (nearer or farther
   than the neck) decoded together, four readings a frame; the nose must be in front of the torso
   (`face_weight`). The hips hang from the neck on the far side (the camera at or above the
   chest), their line parallel to the shoulders'.
4. Each arm: upper arm and forearm, four readings a frame, decoded given the torso, with the
   anatomical costs (`anatomy_weight`): the elbow folds no further than `max_elbow_bend_deg`,
   the upper arm reaches behind the torso no further than `max_behind` (a unit vector's backward
   component), neither elbow nor hand inside the torso; the hand slightly prefers the front
   (`front_weight`). With BlazePose world landmarks, each bone's direction is held near theirs
   (`detector_weight`).
5. Eyes and ears: whichever reading lies further behind the nose along the torso's forward.

Each decoding is a second-order Viterbi path (depth_sign.decode_path) costing the joints' speed
and acceleration in units of `speed_m_s` and `accel_m_s2`.

Output: Pose3D in the camera frame (x right, y down, z forward), metres as far as the assumed
shoulder width; knees and ankles NaN; a joint whose keypoint (or a parent's) is missing or below
the `fitted` section's `min_confidence` is NaN.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import median_filter

from gesturebank.config import Config, FittedConfig, GeometricConfig, ResolvedConfig
from gesturebank.errors import InputError
from gesturebank.lift import TakeViews
from gesturebank.lift.depth_sign import (
    behind_cost,
    decode_path,
    elbow_fold_cost,
    inside_torso_cost,
    ray_candidates,
    rays,
    torso_frame,
)
from gesturebank.lift.fitted import pinhole
from gesturebank.lift.geometric import chain_confidence
from gesturebank.poses import Pose3D
from gesturebank.skeletons import COCO17

_I = COCO17.index
_LS, _RS, _LH, _RH, _NOSE = (
    _I[j] for j in ("left_shoulder", "right_shoulder", "left_hip", "right_hip", "nose")
)
_FACE_BONES = (("nose", "left_eye"), ("nose", "right_eye"), ("left_eye", "left_ear"),
               ("right_eye", "right_ear"))  # fmt: skip


@dataclass(frozen=True, eq=False)
class _Scene:
    """What the decoding stages share, over the take's T frames (camera axes, metres)."""

    ray: np.ndarray  # (T, 17, 3) unit rays through the keypoints (NaN: missing)
    neck: np.ndarray  # (T, 3)
    lengths: dict[str, float]  # bone name → metres
    times: np.ndarray  # (T,)
    world: np.ndarray | None  # (T, 17, 3) the detector's 3D landmarks in camera axes, or None
    pixels: np.ndarray  # (T, 17, 2, 2) ideal pixels and the focal length (x, y)


class ResolvedLifter:
    name = "resolved"

    def __init__(
        self,
        *,
        resolved: ResolvedConfig | None = None,
        fitted: FittedConfig | None = None,
        geometric: GeometricConfig | None = None,
    ) -> None:
        """resolved: the lifter's section; fitted: its camera (`fov_deg`) and `min_confidence`;
        geometric: `shoulder_width_m`, the scale (None: their defaults)."""
        self.options = resolved or ResolvedConfig()
        self.fitted = fitted or FittedConfig()
        self.geometric = geometric or GeometricConfig()

    @classmethod
    def from_config(cls, config: Config) -> ResolvedLifter:
        """The registry's factory (gesturebank.lift): `resolved`, `fitted`, `geometric`."""
        return cls(resolved=config.resolved, fitted=config.fitted, geometric=config.geometric)

    def lift(self, views: TakeViews) -> Pose3D:
        """One view of any skeleton → Pose3D (T, 17, 3), camera frame (module docstring)."""
        pose2d = views.single(self.name)
        if views.cameras is not None and len(views.cameras) != 1:
            raise InputError(
                f"lifter {self.name!r}: one view but {len(views.cameras)} cameras "
                f"({views.cameras.names}); give the view's own camera"
            )
        coco = pose2d.to_coco17()
        kp = coco.keypoints.astype(np.float64)
        conf = np.nan_to_num(kp[..., 2], nan=1.0)
        seen = np.isfinite(kp[..., :2]).all(-1) & (conf >= self.fitted.min_confidence)
        camera = None if views.cameras is None else views.cameras[0]
        focal, center, pixels = pinhole(
            np.where(seen[..., None], kp[..., :2], np.nan),
            coco.image_size,
            camera,
            fov_deg=self.fitted.fov_deg,
        )
        scene = self._scene(pixels, focal, center, coco.timestamps, coco.world)
        joints = np.full((len(kp), len(COCO17), 3), np.nan)
        if scene is not None:
            self._torso(scene, joints)
            for _ in range(2):  # lengths at the decoded parents' depths, then decoded again
                self._arm_lengths(scene, joints)
                for side in ("left", "right"):
                    self._arm(scene, joints, side)
            self._face(scene, joints)
        missing = ~np.isfinite(joints).all(-1)
        joints[missing] = np.nan
        confidence = chain_confidence(np.where(seen, conf, np.nan))
        confidence = np.where(missing, np.nan, confidence)
        return Pose3D(
            joints.astype(np.float32),
            confidence.astype(np.float32),
            coco.timestamps,
            frame="camera",
            units="m",
            meta={"lifter": self.name, "focal_px": f"{focal.mean():.1f}"},
        )

    # ----------------------------------------------------------------------------------------------
    # Stages

    def _scene(
        self,
        pixels: np.ndarray,
        focal: np.ndarray,
        center: np.ndarray,
        times: np.ndarray,
        world: np.ndarray | None,
    ) -> _Scene | None:
        """Rays, the neck's position and the bone lengths; None when no frame has a torso."""
        cfg = self.options
        neck_px = pixels[:, [_LS, _RS]].mean(axis=1)
        hip_px = pixels[:, [_LH, _RH]].mean(axis=1)
        spine_px = np.linalg.norm(neck_px - hip_px, axis=-1)
        ok = np.isfinite(spine_px) & (spine_px > 0)
        if not ok.any():
            return None
        dt = float(np.median(np.diff(times))) if len(times) > 1 else 1.0
        window = max(1, round(cfg.depth_window_s / dt) | 1)
        filled = np.interp(np.arange(len(times)), np.flatnonzero(ok), spine_px[ok])
        spine_smooth = median_filter(filled, size=window, mode="nearest")
        scale = spine_smooth / focal.mean()  # metres per pixel at the neck, per unit spine length

        def ratio(a: np.ndarray, b: np.ndarray) -> float:
            """The take's length of bone a → b, in spine lengths."""
            d = np.linalg.norm(pixels[:, b] - pixels[:, a], axis=-1) / spine_smooth
            d = d[np.isfinite(d)]
            return float(np.percentile(d, cfg.length_percentile)) if d.size else np.nan

        ratios = {
            "shoulders": ratio(np.array(_LS), np.array(_RS)) / 2,
            "hips": ratio(np.array(_LH), np.array(_RH)) / 2,
            "nose": float(
                np.nanpercentile(
                    np.linalg.norm(pixels[:, _NOSE] - neck_px, axis=-1) / spine_smooth,
                    cfg.length_percentile,
                )
            ),
        }
        for a, b in _FACE_BONES:
            ratios[f"{a}-{b}"] = ratio(np.array(_I[a]), np.array(_I[b]))
        spine_m = self.geometric.shoulder_width_m / (2 * ratios["shoulders"])
        lengths = {k: v * spine_m for k, v in ratios.items()} | {"spine": spine_m}
        ray = rays(pixels, focal, center)
        neck_ray = rays(neck_px, focal, center)
        depth = spine_m / scale  # the neck's z
        neck = neck_ray * (depth / neck_ray[:, 2])[:, None]
        cam_world = None
        if world is not None:
            cam_world = np.asarray(world, np.float64)  # BlazePose: camera axes about the hips
        pixel_m = np.stack([pixels, np.broadcast_to(focal, pixels.shape)], axis=-1)
        return _Scene(ray, neck, lengths, times, cam_world, pixel_m)

    def _torso(self, scene: _Scene, joints: np.ndarray) -> None:
        """Shoulders, hips and nose: states (shoulder line, nose) decoded together."""
        cfg, L = self.options, scene.lengths
        neck, ray = scene.neck, scene.ray
        left = ray_candidates(neck, ray[:, _LS], L["shoulders"])
        right = ray_candidates(neck, ray[:, _RS], L["shoulders"])
        nose = ray_candidates(neck, ray[:, _NOSE], L["nose"])
        mid_hip_ray = ray[:, [_LH, _RH]].mean(axis=1)
        mid_hip_ray /= np.linalg.norm(mid_hip_ray, axis=-1, keepdims=True)
        mid_hip = ray_candidates(neck, mid_hip_ray, L["spine"])[1]
        states = [(s, n) for s in (0, 1) for n in (0, 1)]  # s = 0: left shoulder nearer
        positions = np.stack(
            [np.stack([left[s], right[1 - s], nose[n]], axis=1) for s, n in states], axis=1
        )  # (T, 4, 3, 3)
        unary = np.zeros(positions.shape[:2])
        for k, (s, n) in enumerate(states):
            forward = torso_frame(left[s], right[1 - s], mid_hip)[0]
            ahead = np.sum((nose[n] - neck) * forward, -1) / L["nose"]
            unary[:, k] = cfg.face_weight * np.clip(cfg.face_ahead - ahead, 0.0, None)
        path = decode_path(positions, unary, scene.times, speed=cfg.speed_m_s, accel=cfg.accel_m_s2)
        t = np.arange(len(path))
        chosen = positions[t, path]
        joints[:, _LS], joints[:, _RS], joints[:, _NOSE] = chosen[:, 0], chosen[:, 1], chosen[:, 2]
        left_near = np.array([states[p][0] == 0 for p in path])
        for hip, near_with_left in ((_LH, True), (_RH, False)):
            near, far = ray_candidates(mid_hip, ray[:, hip], L["hips"])
            pick_near = left_near == near_with_left
            joints[:, hip] = np.where(pick_near[:, None], near, far)

    def _arm_lengths(self, scene: _Scene, joints: np.ndarray) -> None:
        """Upper arm and forearm lengths: each 2D length in metres at its parent's depth (the
        shoulder's; the elbow's once decoded): a bone nearer the camera looks longer."""
        pixels, focal = scene.pixels[..., 0], scene.pixels[..., 1]
        for part, (a, b) in {"upper": ("shoulder", "elbow"), "fore": ("elbow", "wrist")}.items():
            sides = []
            for side in ("left", "right"):
                i, j = _I[f"{side}_{a}"], _I[f"{side}_{b}"]
                depth = joints[:, i, 2]
                if not np.isfinite(depth).any():
                    depth = joints[:, _I[f"{side}_shoulder"], 2]
                metres = np.linalg.norm((pixels[:, j] - pixels[:, i]) / focal[:, i], axis=-1)
                metres = (metres * depth)[np.isfinite(metres * depth)]
                if metres.size:
                    sides.append(np.percentile(metres, self.options.length_percentile))
            scene.lengths[part] = float(np.mean(sides)) if sides else np.nan

    def _arm(self, scene: _Scene, joints: np.ndarray, side: str) -> None:
        """Elbow and wrist of one arm: states (upper arm, forearm) decoded given the torso."""
        cfg, L = self.options, scene.lengths
        s, e, w = (_I[f"{side}_{j}"] for j in ("shoulder", "elbow", "wrist"))
        shoulder = joints[:, s]
        mid_hip = joints[:, [_LH, _RH]].mean(axis=1)
        frame = torso_frame(joints[:, _LS], joints[:, _RS], mid_hip)
        neck = (joints[:, _LS] + joints[:, _RS]) / 2
        elbows = ray_candidates(shoulder, scene.ray[:, e], L["upper"])
        states = [(u, f) for u in (0, 1) for f in (0, 1)]
        positions = np.empty((len(shoulder), 4, 2, 3))
        unary = np.zeros((len(shoulder), 4))
        box = {"half_width": L["shoulders"] * 0.8, "height": L["spine"], "half_depth": 0.1}
        for k, (u, f) in enumerate(states):
            elbow = elbows[u]
            wrist = ray_candidates(elbow, scene.ray[:, w], L["fore"])[f]
            positions[:, k, 0], positions[:, k, 1] = elbow, wrist
            upper, fore = elbow - shoulder, wrist - elbow
            anatomy = (
                elbow_fold_cost(upper, fore, max_bend_deg=cfg.max_elbow_bend_deg)
                + behind_cost(upper, frame[0], limit=cfg.max_behind)
                + sum(inside_torso_cost(p, neck, frame, **box) for p in (elbow, wrist)) / 0.1
            )
            ahead = np.sum((wrist - shoulder) * frame[0], -1) / (L["upper"] + L["fore"])
            cost = cfg.anatomy_weight * anatomy + cfg.front_weight * np.clip(-ahead, 0.0, None)
            if scene.world is not None:
                for bone, (a, b) in ((upper, (s, e)), (fore, (e, w))):
                    seen = scene.world[:, b] - scene.world[:, a]
                    unit = bone / np.linalg.norm(bone, axis=-1, keepdims=True)
                    ref = seen / np.linalg.norm(seen, axis=-1, keepdims=True)
                    cost = cost + cfg.detector_weight * np.nan_to_num(np.sum((unit - ref) ** 2, -1))
            unary[:, k] = cost
        path = decode_path(positions, unary, scene.times, speed=cfg.speed_m_s, accel=cfg.accel_m_s2)
        chosen = positions[np.arange(len(path)), path]
        joints[:, e], joints[:, w] = chosen[:, 0], chosen[:, 1]

    def _face(self, scene: _Scene, joints: np.ndarray) -> None:
        """Eyes and ears: the reading further behind its parent along the torso's forward."""
        mid_hip = joints[:, [_LH, _RH]].mean(axis=1)
        forward = torso_frame(joints[:, _LS], joints[:, _RS], mid_hip)[0]
        for a, b in _FACE_BONES:
            parent = joints[:, _I[a]]
            near, far = ray_candidates(parent, scene.ray[:, _I[b]], scene.lengths[f"{a}-{b}"])
            behind = np.sum((near - far) * forward, -1) < 0
            joints[:, _I[b]] = np.where(behind[:, None], near, far)
