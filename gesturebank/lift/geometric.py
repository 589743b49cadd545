"""`geometric`: the assumption-based 3D lifter (the dissertation's OP+A, improved).

Works from any 2D detector: the Pose2D is converted to COCO-17 first. Depth comes from
foreshortening: a bone of true length ℓ that measures ℓ_m in the image is tilted out of the image
plane by Δz = sqrt(ℓ² − ℓ_m²) (seed 000 §4.3 "OP+A"); the assumptions below fix ℓ and the sign.

Output frame (`frame="image-ortho"`, right-handed): x to the image's right, y up the image, z out
of the image towards the camera; origin at the take's median neck (mid-shoulders) in the image,
z = 0 on the torso plane. Units: `"relative"` = pixels / image height (default), or `"m"` when
`units="m"`, which scales by an assumed shoulder width (`shoulder_width_m` / the take's shoulder
width in pixels) — an assumption too, so it is off by default.

Joints produced: shoulders and hips from 2D with z = 0 (the torso plane); elbows and wrists with
depth along the arm chains; nose, eyes and ears with depth along a bone from the neck
(mid-shoulders); knees and ankles NaN. A joint whose chain is missing is NaN (never 0).

Assumptions, each with its switch in `GeometricConfig`:

- A1 Orthographic camera (not switchable: it is the model). A pinhole camera bends it a little:
  bones nearer the camera look longer.
- A2 Constant bone lengths, estimated per take as a high percentile (`length_percentile`) of each
  bone's 2D length over the frames where both ends are seen (`robust_lengths=True`). The percentile
  ignores a few over-long glitches and, unlike the dissertation's causal running maximum
  (`robust_lengths=False`), does not under-estimate early in the take.
- A3 Torso plane facing the camera (`torso_facing_camera=True`): shoulders and hips at z = 0.
  Off: the torso may turn about its own hips → neck axis; its yaw comes from the foreshortening
  of the shoulder and hip widths, the sign from the nose (a face turned to the image's right means
  the torso turned to its own left; a head turned against the torso fools it), and shoulders and
  hips get ∓Δz/2. "In front" (A4, A5) then means nearer the camera than the parent joint.
- A4 Head and arms in front of the torso plane, towards the camera (`head_in_front`,
  `arms_in_front`): the neck→face and shoulder→elbow depths are taken positive.
- A5 Wrist further from the torso plane than the elbow (`wrist_beyond_elbow`): the forearm depth
  is taken positive too. Off: the wrist may lie on either side of the elbow as long as it stays in
  front of the torso (A4).

With a sign prior switched off, a depth whose sign no remaining assumption decides is ambiguous:
the joint is NaN and flagged, unless |Δz| is within `ambiguity_tolerance` × ℓ (both signs then
give nearly the same point).

Failures the lifter can see, flagged in `GeometricReport` (`lift_with_report`), with the joint's
confidence multiplied by `flag_confidence`:

- too_long: a bone longer in 2D than its estimated length by more than `length_tolerance`
  (inconsistent lengths: a detector glitch, or the person moved nearer the camera). Δz is 0.
- behind: an elbow or wrist seen inside the 2D torso outline (shoulders and hips) with a
  confidence below `visible_confidence`, i.e. hidden by the torso, so behind it, against A4/A5.
  The whole arm (elbow and wrist) is flagged. An arm behind the torso but outside its outline in
  the image looks like its mirror image in front and cannot be seen from one view.
- ambiguous: see above (only with a sign prior off).

Flags propagate down the chain (a flagged elbow flags its wrist).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gesturebank.config import Config, GeometricConfig
from gesturebank.lift import TakeViews
from gesturebank.poses import Pose3D
from gesturebank.skeletons import COCO17

_I = COCO17.index
_FACE = ("nose", "left_eye", "right_eye", "left_ear", "right_ear")
_TORSO = ("left_shoulder", "right_shoulder", "left_hip", "right_hip")


@dataclass(frozen=True, eq=False)
class GeometricReport:
    """What the lifter flagged; arrays are (T, 17) bool in COCO-17 order.

    too_long:  the joint's bone is longer in 2D than its estimated length (Δz set to 0).
    behind:    the joint's arm is hidden by the torso, so behind it (lifted in front anyway).
    ambiguous: the depth sign is undecided (a sign prior is off); the joint is NaN.
    bone_lengths: estimated length of each bone ("parent-child"), output units; with the running
               maximum, its final value.
    """

    too_long: np.ndarray
    behind: np.ndarray
    ambiguous: np.ndarray
    bone_lengths: dict[str, float]

    @property
    def flagged(self) -> np.ndarray:
        """(T, 17) bool: any flag."""
        return self.too_long | self.behind | self.ambiguous

    @property
    def flagged_frames(self) -> np.ndarray:
        """(T,) bool: frames with at least one flagged joint."""
        return np.asarray(self.flagged.any(axis=1))

    def counts(self) -> dict[str, int]:
        """Number of frames carrying each flag (and any flag)."""
        return {
            "too_long": int(self.too_long.any(axis=1).sum()),
            "behind": int(self.behind.any(axis=1).sum()),
            "ambiguous": int(self.ambiguous.any(axis=1).sum()),
            "flagged": int(self.flagged_frames.sum()),
        }


# --------------------------------------------------------------------------------------------------
# Pure functions over arrays


def bone_length_2d(parent: np.ndarray, child: np.ndarray) -> np.ndarray:
    """(T,) image length of a bone from endpoints (T, 2); NaN where an end is missing."""
    return np.asarray(np.hypot(*(child - parent).T))


def take_length(
    measured: np.ndarray, seen: np.ndarray, *, robust: bool, percentile: float
) -> np.ndarray:
    """(T,) estimated true length of a bone from its (T,) 2D lengths over the frames `seen` (T,).

    robust: the `percentile` of the seen lengths over the whole take (the same for every frame);
    else the causal running maximum (the dissertation's OP+A). NaN before any seen frame.
    """
    ok = seen & np.isfinite(measured)
    if robust:
        value = np.percentile(measured[ok], percentile) if ok.any() else np.nan
        return np.full(len(measured), value)
    running = np.maximum.accumulate(np.where(ok, measured, -np.inf)) if len(ok) else measured
    return np.where(np.isfinite(running), running, np.nan)


def foreshortening_depth(length: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """Depth offset Δz = sqrt(ℓ² − ℓ_m²) ≥ 0 of a bone (T,); 0 where ℓ_m ≥ ℓ (OP+A, seed 000)."""
    return np.sqrt(np.clip(length**2 - measured**2, 0.0, None))


def choose_sign(
    parent_z: np.ndarray,
    dz: np.ndarray,
    *,
    length: np.ndarray,
    prior: bool,
    keep_front: bool,
    tolerance: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Child depth (T,) from the parent's depth and Δz ≥ 0, and (T,) bool ambiguous.

    prior: the sign prior holds (child further towards the camera): z = parent + Δz.
    Otherwise the sign is undecided — unless Δz ≤ tolerance·ℓ, or `keep_front` (the child must stay
    in front of the torso plane, z ≥ 0) rules the other candidate out — and the depth is NaN.
    """
    front = parent_z + dz
    if prior:
        return front, np.zeros(len(dz), dtype=bool)
    decided = dz <= tolerance * length
    if keep_front:
        decided |= parent_z - dz < 0
    ambiguous = ~decided & np.isfinite(front)
    return np.where(ambiguous, np.nan, front), ambiguous


def inside_quad(points: np.ndarray, quad: np.ndarray) -> np.ndarray:
    """(T,) bool: 2D points (T, 2) strictly inside convex quadrilaterals (T, 4, 2) (either winding).

    False where anything is missing.
    """
    edges = np.roll(quad, -1, axis=1) - quad  # (T, 4, 2)
    rel = points[:, None, :] - quad
    cross = edges[..., 0] * rel[..., 1] - edges[..., 1] * rel[..., 0]  # (T, 4)
    with np.errstate(invalid="ignore"):
        return np.asarray((cross > 0).all(axis=1) | (cross < 0).all(axis=1))


def torso_yaw_depths(
    xy: np.ndarray, seen: np.ndarray, *, cfg: GeometricConfig
) -> tuple[np.ndarray, np.ndarray]:
    """A3 off: depths (T, 4) of (left/right shoulder, left/right hip) and (T,) bool ambiguous.

    xy: (T, 17, 2) pixels (y down); seen: (T, 17) bool. The shoulder (hip) line turned by the yaw
    θ is foreshortened by |Δz| = sqrt(w² − w_m²); the nose's offset from the neck along the shoulder
    line gives sign(θ); turning to its own left (θ > 0) moves the left shoulder away (z < 0).
    """
    ls, rs, lh, rh = (xy[:, _I[n]] for n in _TORSO)
    neck = (ls + rs) / 2
    sign = np.sign(np.sum((xy[:, _I["nose"]] - neck) * (ls - rs), axis=-1))
    out = np.zeros((len(xy), 4))
    ambiguous = np.zeros(len(xy), dtype=bool)
    for k, (a, b, na, nb) in enumerate(
        ((ls, rs, "left_shoulder", "right_shoulder"), (lh, rh, "left_hip", "right_hip"))
    ):
        measured = bone_length_2d(b, a)
        length = take_length(
            measured,
            seen[:, _I[na]] & seen[:, _I[nb]],
            robust=cfg.robust_lengths,
            percentile=cfg.length_percentile,
        )
        dz = foreshortening_depth(length, measured)
        with np.errstate(invalid="ignore"):
            undecided = ~(np.abs(sign) > 0) & (dz > cfg.ambiguity_tolerance * length)
        ambiguous |= undecided & np.isfinite(dz)
        half = np.where(undecided, np.nan, np.nan_to_num(sign) * dz / 2)
        out[:, 2 * k], out[:, 2 * k + 1] = -half, half
    return out, ambiguous


@dataclass(frozen=True, eq=False)
class _Lifted:
    z: np.ndarray  # (T, 17) depth, pixels, towards the camera
    too_long: np.ndarray  # (T, 17) bool
    behind: np.ndarray  # (T, 17) bool
    ambiguous: np.ndarray  # (T, 17) bool
    lengths: dict[str, np.ndarray]  # bone → (T,) estimated length, pixels


def lift_depths(xy: np.ndarray, confidence: np.ndarray, *, cfg: GeometricConfig) -> _Lifted:
    """Depths (pixels, z towards the camera, 0 on the torso plane) of COCO-17 keypoints.

    xy: (T, 17, 2) pixels, NaN = missing; confidence: (T, 17) in [0, 1].
    """
    n = len(xy)
    seen = confidence >= cfg.visible_confidence
    z = np.full((n, len(COCO17)), np.nan)
    flags = {k: np.zeros((n, len(COCO17)), dtype=bool) for k in ("too_long", "behind", "ambig")}
    lengths: dict[str, np.ndarray] = {}
    torso = [_I[j] for j in _TORSO]
    if cfg.torso_facing_camera:
        z[:, torso] = 0.0
    else:
        z[:, torso], amb = torso_yaw_depths(xy, seen, cfg=cfg)
        flags["ambig"][:, torso] |= amb[:, None]
    z = np.where(np.isfinite(xy).all(axis=-1), z, np.nan)

    def bone(parent_xy: np.ndarray, parent_seen: np.ndarray, child: str) -> tuple[np.ndarray, ...]:
        measured = bone_length_2d(parent_xy, xy[:, _I[child]])
        length = take_length(
            measured,
            parent_seen & seen[:, _I[child]],
            robust=cfg.robust_lengths,
            percentile=cfg.length_percentile,
        )
        too_long = measured > (1.0 + cfg.length_tolerance) * length
        return foreshortening_depth(length, measured), length, too_long

    # Head: a bone from the neck (mid-shoulders, on the torso plane) to each face keypoint (A4).
    ls, rs = _I["left_shoulder"], _I["right_shoulder"]
    neck_xy, neck_z = (xy[:, ls] + xy[:, rs]) / 2, (z[:, ls] + z[:, rs]) / 2
    for name in _FACE:
        dz, length, long_ = bone(neck_xy, seen[:, ls] & seen[:, rs], name)
        j = _I[name]
        z[:, j], flags["ambig"][:, j] = choose_sign(
            neck_z,
            dz,
            length=length,
            prior=cfg.head_in_front,
            keep_front=False,
            tolerance=cfg.ambiguity_tolerance,
        )
        flags["too_long"][:, j] = long_
        lengths[f"neck-{name}"] = length

    quad = xy[:, [_I[j] for j in ("left_shoulder", "right_shoulder", "right_hip", "left_hip")]]
    for side in ("left", "right"):
        s, e, w = (_I[f"{side}_{j}"] for j in ("shoulder", "elbow", "wrist"))
        dz, length, long_ = bone(xy[:, s], seen[:, s], f"{side}_elbow")
        z[:, e], flags["ambig"][:, e] = choose_sign(
            z[:, s],
            dz,
            length=length,
            prior=cfg.arms_in_front,
            keep_front=False,
            tolerance=cfg.ambiguity_tolerance,
        )
        flags["too_long"][:, e] = long_
        lengths[f"{side}_shoulder-{side}_elbow"] = length
        dz, length, long_ = bone(xy[:, e], seen[:, e], f"{side}_wrist")
        # A5 off: the wrist may be on either side of the elbow but stays in front (A4) if on.
        z[:, w], flags["ambig"][:, w] = choose_sign(
            z[:, e],
            dz,
            length=length,
            prior=cfg.wrist_beyond_elbow,
            keep_front=cfg.arms_in_front,
            tolerance=cfg.ambiguity_tolerance,
        )
        flags["too_long"][:, w] = long_
        lengths[f"{side}_elbow-{side}_wrist"] = length
        # Hidden by the torso (inside its outline, not seen) means behind it: the arm breaks A4/A5.
        hidden = [inside_quad(xy[:, j], quad) & ~seen[:, j] for j in (e, w)]
        flags["behind"][:, [e, w]] = (hidden[0] | hidden[1])[:, None]
        for f in flags.values():  # a flagged elbow (or shoulder) taints its wrist
            f[:, e] |= f[:, s]
            f[:, w] |= f[:, e]
    return _Lifted(z, flags["too_long"], flags["behind"], flags["ambig"], lengths)


def chain_confidence(confidence: np.ndarray) -> np.ndarray:
    """(T, 17) confidence of each lifted joint: the lowest along the keypoints it depends on."""
    c = confidence.copy()
    ls, rs = _I["left_shoulder"], _I["right_shoulder"]
    for name in _FACE:
        c[:, _I[name]] = np.minimum(c[:, _I[name]], np.minimum(c[:, ls], c[:, rs]))
    for side in ("left", "right"):
        s, e, w = (_I[f"{side}_{j}"] for j in ("shoulder", "elbow", "wrist"))
        c[:, e] = np.minimum(c[:, e], c[:, s])
        c[:, w] = np.minimum(c[:, w], c[:, e])
    return c


# --------------------------------------------------------------------------------------------------
# The lifter


class GeometricLifter:
    name = "geometric"

    def __init__(self, *, geometric: GeometricConfig | None = None) -> None:
        """geometric: the lifter's section (None: its defaults)."""
        self.options = geometric or GeometricConfig()

    @classmethod
    def from_config(cls, config: Config) -> GeometricLifter:
        """The registry's factory (gesturebank.lift): the `geometric` section."""
        return cls(geometric=config.lifter.geometric)

    def lift(self, views: TakeViews) -> Pose3D:
        """One view of any skeleton → Pose3D (T, 17, 3), frame "image-ortho" (module docstring)."""
        return self.lift_with_report(views)[0]

    def lift_with_report(self, views: TakeViews) -> tuple[Pose3D, GeometricReport]:
        """As `lift`, plus what was flagged (flagged joints also get a lower confidence)."""
        pose2d = views.single(self.name)
        cfg = self.options
        kp = pose2d.to_coco17().keypoints.astype(np.float64)
        # A keypoint without a score counts as fully confident; a too-unsure one as missing.
        conf = np.where(np.isnan(kp[..., 2]), 1.0, kp[..., 2])
        usable = np.isfinite(kp[..., :2]).all(axis=-1) & (conf >= cfg.min_confidence)
        xy = np.where(usable[..., None], kp[..., :2], np.nan)
        conf = np.where(usable, conf, np.nan)

        lifted = lift_depths(xy, conf, cfg=cfg)
        scale = self._scale(xy, conf, pose2d.image_size[1])
        neck = (xy[:, _I["left_shoulder"]] + xy[:, _I["right_shoulder"]]) / 2
        origin = np.nanmedian(neck, axis=0) if np.isfinite(neck).any() else np.full(2, np.nan)
        joints = np.stack(
            [xy[..., 0] - origin[0], origin[1] - xy[..., 1], lifted.z], axis=-1
        )  # y flipped: image y points down, ours up; z towards the camera keeps it right-handed
        joints *= scale
        missing = ~np.isfinite(joints).all(axis=-1)
        joints[missing] = np.nan

        report = GeometricReport(
            too_long=lifted.too_long & ~missing,
            behind=lifted.behind & ~missing,
            ambiguous=lifted.ambiguous,
            bone_lengths={
                k: float(v[-1] * scale) if len(v) else float("nan")
                for k, v in lifted.lengths.items()
            },
        )
        confidence = chain_confidence(conf)
        confidence = np.where(report.flagged, confidence * cfg.flag_confidence, confidence)
        confidence = np.where(missing, np.nan, confidence)
        counts = report.counts()
        meta = {
            "lifter": self.name,
            "source_skeleton": pose2d.skeleton,
            **{f"flagged_frames_{k}": str(v) for k, v in counts.items()},
        }
        pose = Pose3D(
            joints.astype(np.float32),
            confidence.astype(np.float32),
            pose2d.timestamps,
            frame="image-ortho",
            units=cfg.units,
            meta=meta,
        )
        return pose, report

    def _scale(self, xy: np.ndarray, conf: np.ndarray, image_height: int) -> float:
        """Output units per pixel: 1 / image height, or the assumed shoulder width in metres."""
        cfg = self.options
        if cfg.units == "relative":
            return 1.0 / image_height
        ls, rs = _I["left_shoulder"], _I["right_shoulder"]
        seen = (conf[:, ls] >= cfg.visible_confidence) & (conf[:, rs] >= cfg.visible_confidence)
        width = take_length(
            bone_length_2d(xy[:, ls], xy[:, rs]),
            seen,
            robust=True,
            percentile=cfg.length_percentile,
        )
        return float(cfg.shoulder_width_m / width[0]) if len(width) else float("nan")
