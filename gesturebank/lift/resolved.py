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
   (`detector_weight`); with `learned_weight`, near the `learned` lifter's lift of the same 2D
   (its network reads the depth from how the 2D moves).
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

from gesturebank.config import Config, FittedConfig, GeometricConfig, LearnedConfig, ResolvedConfig
from gesturebank.lift import LifterTraits, TakeViews
from gesturebank.lift.depth_confidence import RESOLVED
from gesturebank.lift.depth_sign import (
    behind_cost,
    decode_path,
    depth_readings,
    elbow_fold_cost,
    inside_torso_cost,
    ray_candidates,
    rays,
    torso_frame,
    torso_scale,
)
from gesturebank.lift.fitted import pinhole
from gesturebank.lift.geometric import chain_confidence
from gesturebank.lift.learned import LearnedLifter
from gesturebank.poses import Pose3D
from gesturebank.skeletons import COCO17

_I = COCO17.index
_LS, _RS, _LH, _RH, _NOSE = (
    _I[j] for j in ("left_shoulder", "right_shoulder", "left_hip", "right_hip", "nose")
)
_FACE_BONES = (("nose", "left_eye"), ("nose", "right_eye"), ("left_eye", "left_ear"),
               ("right_eye", "right_ear"))  # fmt: skip


def ray_pair(
    parent: np.ndarray, ray: np.ndarray, *, length: float
) -> tuple[np.ndarray, np.ndarray]:
    """The arms' readings: the exact near and far points (T, 2, 3), costing nothing (T, 2).
    Depth levels along the ray (as for the shoulder line) were worse for the arms on test.bvh."""
    return depth_readings(parent, ray, length=length, levels=2, length_sd=1.0)


def _expand(frame: tuple[np.ndarray, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A torso frame of (T, 3) axes broadcast over readings: (T, 1, 3) each."""
    forward, left, up = (axis[:, None] for axis in frame)
    return forward, left, up


@dataclass(frozen=True, eq=False)
class _Scene:
    """What the decoding stages share, over the take's T frames (camera axes, metres)."""

    ray: np.ndarray  # (T, 17, 3) unit rays through the keypoints (NaN: missing)
    neck: np.ndarray  # (T, 3)
    lengths: dict[str, float]  # bone name → metres
    times: np.ndarray  # (T,)
    references: tuple[tuple[np.ndarray, float], ...]  # (T, 17, 3) 3D in camera axes, weight
    pixels: np.ndarray  # (T, 17, 2, 2) ideal pixels and the focal length (x, y)


class ResolvedLifter:
    name = "resolved"
    traits = LifterTraits(depth_calibration=RESOLVED)

    def __init__(
        self,
        *,
        resolved: ResolvedConfig | None = None,
        fitted: FittedConfig | None = None,
        geometric: GeometricConfig | None = None,
        learned: LearnedConfig | None = None,
    ) -> None:
        """resolved: the lifter's section; fitted: its camera (`fov_deg`) and `min_confidence`;
        geometric: `shoulder_width_m`, the scale; learned: the network whose 3D guides the signs
        (`learned_weight`) (None: their defaults)."""
        self.options = resolved or ResolvedConfig()
        self.fitted = fitted or FittedConfig()
        self.geometric = geometric or GeometricConfig()
        self.learned = learned or LearnedConfig()

    @classmethod
    def from_config(cls, config: Config) -> ResolvedLifter:
        """The registry's factory (gesturebank.lift): `resolved`, `fitted`, `geometric`,
        `learned`."""
        own = config.lifter
        return cls(resolved=own.resolved, fitted=own.fitted, geometric=own.geometric,
                   learned=own.learned)  # fmt: skip

    def lift(self, views: TakeViews) -> Pose3D:
        """One view of any skeleton → Pose3D (T, 17, 3), camera frame (module docstring)."""
        pose2d = views.single(self.name)
        coco = pose2d.to_coco17()
        kp = coco.keypoints.astype(np.float64)
        conf = np.nan_to_num(kp[..., 2], nan=1.0)
        seen = np.isfinite(kp[..., :2]).all(-1) & (conf >= self.fitted.min_confidence)
        camera = views.single_camera(self.name)
        focal, center, pixels = pinhole(
            np.where(seen[..., None], kp[..., :2], np.nan),
            coco.image_size,
            camera=camera,
            fov_deg=self.fitted.fov_deg,
        )
        references = []
        if coco.world is not None:  # BlazePose: camera axes about the hips
            references.append((np.asarray(coco.world, np.float64), self.options.detector_weight))
        if self.options.learned_weight > 0:
            net = LearnedLifter(learned=self.learned, fitted=self.fitted, geometric=self.geometric)
            learned = net.lift(views).joints.astype(np.float64)
            references.append((learned, self.options.learned_weight))
        scene = self._scene(pixels, focal, center, coco.timestamps, tuple(references))
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
        references: tuple[tuple[np.ndarray, float], ...],
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
        px = {
            "shoulders": np.linalg.norm(pixels[:, _LS] - pixels[:, _RS], axis=-1) / 2,
            "hips": np.linalg.norm(pixels[:, _LH] - pixels[:, _RH], axis=-1) / 2,
            "spine": spine_px,
        }
        scale = torso_scale(px, ok, window=window, percentile=cfg.length_percentile)

        def ratio(bone_px: np.ndarray) -> float:
            """The take's length of a bone seen `bone_px` (T,) long, in scale units."""
            d = bone_px / scale
            d = d[np.isfinite(d)]
            return float(np.percentile(d, cfg.length_percentile)) if d.size else np.nan

        ratios = {k: ratio(v) for k, v in px.items()}
        ratios["nose"] = ratio(np.linalg.norm(pixels[:, _NOSE] - neck_px, axis=-1))
        for a, b in _FACE_BONES:
            ratios[f"{a}-{b}"] = ratio(np.linalg.norm(pixels[:, _I[b]] - pixels[:, _I[a]], axis=-1))
        metres = self.geometric.shoulder_width_m / (2 * ratios["shoulders"])  # per scale unit
        lengths = {k: v * metres for k, v in ratios.items()}
        depth = focal.mean() * metres / scale  # the neck's z
        ray = rays(pixels, focal, center=center)
        neck_ray = rays(neck_px, focal, center=center)
        neck = neck_ray * (depth / neck_ray[:, 2])[:, None]
        pixel_m = np.stack([pixels, np.broadcast_to(focal, pixels.shape)], axis=-1)
        return _Scene(ray, neck, lengths, times, references, pixel_m)

    def _torso(self, scene: _Scene, joints: np.ndarray) -> None:
        """Shoulders, hips and nose: states (shoulder line, nose) decoded together."""
        cfg, L = self.options, scene.lengths
        neck, ray = scene.neck, scene.ray
        left, left_cost = depth_readings(
            neck,
            ray[:, _LS],
            length=L["shoulders"],
            levels=cfg.depth_levels,
            length_sd=cfg.length_sd,
        )
        right, right_cost = depth_readings(
            neck,
            ray[:, _RS],
            length=L["shoulders"],
            levels=cfg.depth_levels,
            length_sd=cfg.length_sd,
        )
        nose = ray_candidates(neck, ray[:, _NOSE], length=L["nose"])
        mid_hip_ray = ray[:, [_LH, _RH]].mean(axis=1)
        mid_hip_ray /= np.linalg.norm(mid_hip_ray, axis=-1, keepdims=True)
        mid_hip = ray_candidates(neck, mid_hip_ray, length=L["spine"])[1]
        n_levels = left.shape[1]  # reading k of the left shoulder goes with n−1−k of the right
        states = [(k, n) for k in range(n_levels) for n in (0, 1)]
        positions = np.stack(
            [np.stack([left[:, k], right[:, n_levels - 1 - k], nose[n]], 1) for k, n in states],
            axis=1,
        )  # (T, S, 3, 3)
        unary = np.zeros(positions.shape[:2])
        for i, (k, n) in enumerate(states):
            forward = torso_frame(left[:, k], right[:, n_levels - 1 - k], mid_hip=mid_hip)[0]
            ahead = np.sum((nose[n] - neck) * forward, -1) / L["nose"]
            unary[:, i] = cfg.face_weight * np.clip(cfg.face_ahead - ahead, 0.0, None)
            unary[:, i] += left_cost[:, k] + right_cost[:, n_levels - 1 - k]
        path = decode_path(
            positions, unary, times=scene.times, speed=cfg.speed_m_s, accel=cfg.accel_m_s2
        )
        t = np.arange(len(path))
        chosen = positions[t, path]
        joints[:, _LS], joints[:, _RS], joints[:, _NOSE] = chosen[:, 0], chosen[:, 1], chosen[:, 2]
        # the hip line turned as the shoulder line: its left end as much nearer or farther
        shoulder_dz = joints[:, _LS, 2] - joints[:, _RS, 2]
        hips = [ray_candidates(mid_hip, ray[:, h], length=L["hips"]) for h in (_LH, _RH)]
        left_hip_near = shoulder_dz < 0
        joints[:, _LH] = np.where(left_hip_near[:, None], hips[0][0], hips[0][1])
        joints[:, _RH] = np.where(left_hip_near[:, None], hips[1][1], hips[1][0])

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
        frame = torso_frame(joints[:, _LS], joints[:, _RS], mid_hip=mid_hip)
        neck = (joints[:, _LS] + joints[:, _RS]) / 2
        box = {"half_width": L["shoulders"] * 0.8, "height": L["spine"], "half_depth": 0.1}
        motion = {"speed": cfg.speed_m_s, "accel": cfg.accel_m_s2}
        elbows, cost = ray_pair(shoulder, scene.ray[:, e], length=L["upper"])
        upper = elbows - shoulder[:, None]
        cost = cost + cfg.anatomy_weight * (
            behind_cost(upper, frame[0][:, None], limit=cfg.max_behind)
            + inside_torso_cost(elbows, neck[:, None], frame=_expand(frame), **box) / 0.1
        )
        cost = cost + self._detector_cost(scene, upper, s, e)
        path = decode_path(elbows[:, :, None], cost, times=scene.times, **motion)
        elbow = elbows[np.arange(len(path)), path]
        joints[:, e] = elbow
        wrists, cost = ray_pair(elbow, scene.ray[:, w], length=L["fore"])
        fore = wrists - elbow[:, None]
        ahead = np.sum((wrists - shoulder[:, None]) * frame[0][:, None], -1)
        ahead = ahead / (L["upper"] + L["fore"])
        cost = cost + cfg.anatomy_weight * (
            elbow_fold_cost((elbow - shoulder)[:, None], fore, max_bend_deg=cfg.max_elbow_bend_deg)
            + inside_torso_cost(wrists, neck[:, None], frame=_expand(frame), **box) / 0.1
        )
        cost = cost + cfg.front_weight * np.clip(-ahead, 0.0, None)
        cost = cost + self._detector_cost(scene, fore, e, w)
        path = decode_path(wrists[:, :, None], cost, times=scene.times, **motion)
        joints[:, w] = wrists[np.arange(len(path)), path]

    def _detector_cost(self, scene: _Scene, bones: np.ndarray, a: int, b: int) -> np.ndarray:
        """(T, S) cost of each reading's bone (T, S, 3) pointing away from the references' own
        3D bone a → b (the detector's world landmarks, the learned net's lift), each weighted;
        0 without references."""
        cost = np.zeros(bones.shape[:2])
        unit = bones / np.linalg.norm(bones, axis=-1, keepdims=True)
        for joints, weight in scene.references:
            seen = joints[:, b] - joints[:, a]
            ref = seen / np.linalg.norm(seen, axis=-1, keepdims=True)
            cost += weight * np.nan_to_num(np.sum((unit - ref[:, None]) ** 2, -1))
        return cost

    def _face(self, scene: _Scene, joints: np.ndarray) -> None:
        """Eyes and ears: the reading further behind its parent along the torso's forward."""
        mid_hip = joints[:, [_LH, _RH]].mean(axis=1)
        forward = torso_frame(joints[:, _LS], joints[:, _RS], mid_hip=mid_hip)[0]
        for a, b in _FACE_BONES:
            parent = joints[:, _I[a]]
            near, far = ray_candidates(
                parent, scene.ray[:, _I[b]], length=scene.lengths[f"{a}-{b}"]
            )
            behind = np.sum((near - far) * forward, -1) < 0
            joints[:, _I[b]] = np.where(behind[:, None], near, far)
