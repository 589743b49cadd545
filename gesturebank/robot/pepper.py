"""Pepper: the 11 controlled joints, robot profiles (limits as data), and forward kinematics.

Angles are `(N, 11)` arrays in radians, columns in the dissertation's order (`JOINTS`), with
NAOqi's signs and zeros (docs/architecture.md "Pepper angles").
Everything here is a pure function over arrays;
NaN (a missing angle) passes through unchanged.

Robot frame (URDF): x forward, y to the robot's left, z up, origin at the HipRoll pivot.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Literal

import numpy as np

from gesturebank.errors import InputError
from gesturebank.geometry import axis_rotations as axis_rotations  # first defined here

JOINTS = (
    "HeadPitch",
    "HeadYaw",
    "LShoulderRoll",
    "LShoulderPitch",
    "LElbowRoll",
    "LElbowYaw",
    "RShoulderRoll",
    "RShoulderPitch",
    "RElbowRoll",
    "RElbowYaw",
    "HipRoll",
)
# The joints that move Pepper's head: what a listener model predicts and `live --role listener`
# drives (seed 004's nod and yaw; Pepper has no head roll).
HEAD_JOINTS = ("HeadPitch", "HeadYaw")
INDEX = {name: i for i, name in enumerate(JOINTS)}
DEFAULT_PROFILE = "pepper-1.7"
_PROFILE_FILES = {"pepper-1.7": "pepper-1.7.toml", "pepper-1.8": "pepper-1.8.toml"}


# --------------------------------------------------------------------------------------------------
# Profiles


@dataclass(frozen=True, eq=False)
class RobotProfile:
    """Limits of one robot variant, read from `gesturebank/data/<name>.toml`.

    lower, upper: (11,) float64 radians; velocity: (11,) float64 rad/s; all in `JOINTS` order.
    """

    name: str
    description: str
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray

    @property
    def joints(self) -> tuple[str, ...]:
        return JOINTS

    def as_dict(self) -> dict[str, dict[str, float]]:
        """Plain-data view (for dataset.json)."""
        return {
            j: {"lower": float(lo), "upper": float(hi), "velocity": float(v)}
            for j, lo, hi, v in zip(JOINTS, self.lower, self.upper, self.velocity, strict=True)
        }


def available_profiles() -> tuple[str, ...]:
    """Names accepted by `load_profile`."""
    return tuple(_PROFILE_FILES)


@cache
def load_profile(name: str = DEFAULT_PROFILE) -> RobotProfile:
    """The robot profile `name` (e.g. "pepper-1.7", "pepper-1.8"); InputError if unknown or bad."""
    if name not in _PROFILE_FILES:
        raise InputError(
            f"unknown robot profile {name!r}; known profiles: {', '.join(available_profiles())}"
        )
    fname = _PROFILE_FILES[name]
    text = resources.files("gesturebank").joinpath("data", fname).read_text(encoding="utf-8")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"robot profile {fname}: not valid TOML ({exc})") from None
    return _profile_from_dict(data, fname)


def _profile_from_dict(data: dict, where: str) -> RobotProfile:
    joints = data.get("joints", {})
    missing = [j for j in JOINTS if j not in joints]
    if missing:
        raise InputError(f"robot profile {where}: joints missing: {', '.join(missing)}")
    try:
        table = np.array(
            [[float(joints[j][k]) for k in ("lower", "upper", "velocity")] for j in JOINTS]
        )
    except (KeyError, TypeError, ValueError) as exc:
        msg = f"robot profile {where}: each joint needs lower, upper, velocity ({exc})"
        raise InputError(msg) from None
    lower, upper, velocity = table.T
    bad = [j for j, lo, hi in zip(JOINTS, lower, upper, strict=True) if not lo < hi]
    if bad or not np.all(velocity > 0):
        raise InputError(f"robot profile {where}: need lower < upper and velocity > 0 ({bad})")
    return RobotProfile(
        name=str(data.get("name", where)),
        description=str(data.get("description", "")),
        lower=lower,
        upper=upper,
        velocity=velocity,
    )


def _profile(profile: RobotProfile | str | None) -> RobotProfile:
    if profile is None:
        return load_profile(DEFAULT_PROFILE)
    if isinstance(profile, str):
        return load_profile(profile)
    return profile


def _angles(angles: np.ndarray, what: str) -> np.ndarray:
    a = np.asarray(angles, dtype=np.float64)
    if a.ndim == 0 or a.shape[-1] != len(JOINTS):
        raise InputError(f"{what}: angles must have shape (N, 11), got {a.shape}")
    return a


# --------------------------------------------------------------------------------------------------
# Poses, limits, normalisation


def neutral_pose() -> np.ndarray:
    """(11,) float32: all joints 0 except both ShoulderPitch = π/2 (arms hanging).

    The four roll joints' limits exclude exactly 0 (±0.0087), so `clamp` moves them by 0.5°.
    """
    pose = np.zeros(len(JOINTS), dtype=np.float32)
    pose[[INDEX["LShoulderPitch"], INDEX["RShoulderPitch"]]] = np.pi / 2
    return pose


def clamp(angles: np.ndarray, profile: RobotProfile | str | None = None) -> np.ndarray:
    """Clip `(N, 11)` angles into the profile's limits; NaN stays NaN; float dtype kept."""
    p = _profile(profile)
    a = _angles(angles, "clamp")
    dtype = np.result_type(np.asarray(angles).dtype, np.float32)
    # Limits rounded inward in the output dtype: float32(2.0857) is above 2.0857, so clipping in
    # float64 and casting afterwards could land just outside the limit.
    lower, upper = p.lower.astype(dtype), p.upper.astype(dtype)
    lower = np.where(lower < p.lower, np.nextafter(lower, dtype.type(np.inf)), lower)
    upper = np.where(upper > p.upper, np.nextafter(upper, dtype.type(-np.inf)), upper)
    return np.clip(a.astype(dtype), lower, upper)


def normalise(angles: np.ndarray, profile: RobotProfile | str | None = None) -> np.ndarray:
    """`(N, 11)` radians → `(N, 11)` in [0, 1] within the limits (Eq. 3.13–3.14).

    0 at the lower limit, 1 at the upper; angles outside the limits map outside [0, 1] (clamp
    first, as the dataset pipeline does).
    """
    p = _profile(profile)
    a = _angles(angles, "normalise")
    return ((a - p.lower) / (p.upper - p.lower)).astype(np.float32)  # Eq. 3.14


def denormalise(angles01: np.ndarray, profile: RobotProfile | str | None = None) -> np.ndarray:
    """Inverse of `normalise` (ν⁻¹ of Eq. 3.14): `(N, 11)` in [0, 1] → `(N, 11)` radians."""
    p = _profile(profile)
    a = _angles(angles01, "denormalise")
    return (p.lower + a * (p.upper - p.lower)).astype(np.float32)


def limit_velocity(
    angles: np.ndarray,
    dt: float | None = None,
    *,
    timestamps: np.ndarray | None = None,
    profile: RobotProfile | str | None = None,
    start: np.ndarray | None = None,
) -> np.ndarray:
    """Bound every joint's speed by the profile's velocity (rad/s): `(N, 11)` → `(N, 11)` float32.

    Give either a fixed step `dt` (s) or `timestamps (N,)` (s, increasing). Each output follows its
    input as closely as the speed allows: y[t] = y[t₀] + clip(x[t] − y[t₀], ±v·(t − t₀)), where t₀
    is the joint's previous valid sample (a NaN input gives a NaN output and the allowed step grows
    over the gap). `start (11,)` is the pose one step before the first sample (e.g. the robot's
    current pose); without it the first valid sample passes unchanged.

    The recurrence is inherently sequential, so this loops over frames (vectorised over joints).
    """
    p = _profile(profile)
    a = _angles(angles, "limit_velocity")
    if a.ndim != 2:
        raise InputError(f"limit_velocity: angles must have shape (N, 11), got {a.shape}")
    n = len(a)
    if (dt is None) == (timestamps is None):
        raise InputError("limit_velocity: give exactly one of dt or timestamps")
    if timestamps is not None:
        t = np.asarray(timestamps, dtype=np.float64)
        if t.shape != (n,) or (n > 1 and not np.all(np.diff(t) > 0)):
            raise InputError(f"limit_velocity: timestamps must be increasing, shape ({n},)")
    else:
        if not dt or dt <= 0:
            raise InputError(f"limit_velocity: dt must be > 0, got {dt}")
        t = np.arange(n, dtype=np.float64) * dt
    out = np.full_like(a, np.nan)
    if start is None:
        ref = np.full(len(JOINTS), np.nan)
        t_ref = np.full(len(JOINTS), -np.inf)
    else:
        ref = _angles(start, "limit_velocity start").reshape(len(JOINTS)).copy()
        first_step = dt if dt is not None else (t[1] - t[0] if n > 1 else 0.0)
        t_ref = np.full(len(JOINTS), (t[0] if n else 0.0) - first_step)
    for i in range(n):
        x = a[i]
        step = p.velocity * (t[i] - t_ref)
        y = np.where(np.isnan(ref), x, np.clip(x, ref - step, ref + step))
        valid = ~np.isnan(x)
        out[i] = np.where(valid, y, np.nan)
        ref = np.where(valid, y, ref)
        t_ref = np.where(valid, t[i], t_ref)
    return out.astype(np.float32)


# --------------------------------------------------------------------------------------------------
# Forward kinematics


@dataclass(frozen=True)
class Kinematics:
    """Link offsets (metres, robot frame at zero angles) of the chains `fk` evaluates.

    Values of the public Pepper URDF (offline-resources §C3); the "ideal" variant keeps the link
    lengths and drops every offset off the chain's main axis, so that the arm is a pure
    pitch-roll-yaw-roll chain and `retarget.pepper_angles` inverts it exactly.
    """

    shoulder: tuple[float, float, float]  # ShoulderPitch origin (left arm) from the HipRoll pivot
    elbow: tuple[float, float, float]  # ElbowYaw origin (left arm) in the bicep frame
    elbow_pitch: float  # fixed rpy pitch of the ElbowYaw frame (URDF: −0.157079 rad)
    forearm: float  # ElbowRoll → WristYaw along the forearm x axis
    head: tuple[float, float, float]  # HeadYaw origin from the HipRoll pivot
    hip_half_width: float  # virtual hip markers (Pepper has no hips) ± y on the Hip link


# Torso origin sits 0 above the HipRoll pivot in the URDF (HipRoll joint origin is the torso link).
URDF = Kinematics(
    shoulder=(-0.057, 0.14974, 0.22582),
    elbow=(0.1812, 0.015, 0.00013),
    elbow_pitch=-0.157079,
    forearm=0.15,
    head=(-0.038, 0.0, 0.3089),
    hip_half_width=0.10,
)
IDEAL = Kinematics(
    shoulder=(0.0, 0.14974, 0.22582),
    elbow=(0.1812, 0.0, 0.0),
    elbow_pitch=0.0,
    forearm=0.15,
    head=(0.0, 0.0, 0.3089),
    hip_half_width=0.10,
)
MODELS = {"urdf": URDF, "ideal": IDEAL}

# Virtual face markers on the head link (HeadPitch frame), Pepper-sized, so that FK output can be
# fed back to retargeting as COCO-17: eyes and ears at one height (the face direction is
# mid-ears → mid-eyes), nose in the mid-sagittal plane.
FACE_MARKERS = {
    "nose": (0.11, 0.0, 0.08),
    "left_eye": (0.09, 0.035, 0.11),
    "right_eye": (0.09, -0.035, 0.11),
    "left_ear": (0.0, 0.09, 0.11),
    "right_ear": (0.0, -0.09, 0.11),
}


def _apply(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vector(s) v (3,) or (N, 3) by r (N, 3, 3)."""
    return np.einsum("nij,nj->ni", r, np.broadcast_to(v, (len(r), 3)))


def fk(
    angles: np.ndarray, *, model: Literal["urdf", "ideal"] | Kinematics = "urdf"
) -> dict[str, np.ndarray]:
    """Forward kinematics: `(N, 11)` angles → named points `(N, 3)` in metres, robot frame.

    Points: left/right_shoulder (ShoulderPitch joint), left/right_elbow (ElbowYaw joint),
    left/right_wrist (WristYaw joint), head (HeadYaw/HeadPitch joint), pelvis (HipRoll pivot, the
    origin), left/right_hip (virtual, fixed on the Hip link below the shoulders) and the virtual
    face markers of `FACE_MARKERS` on the head link.

    Chains (URDF axes): torso = Rot(−x, HipRoll); arm = torso · Ry(ShoulderPitch) · Rz(ShoulderRoll)
    · [elbow offset, Ry(elbow_pitch)] · Rx(ElbowYaw) · Rz(ElbowRoll) · [forearm]; head = torso ·
    Rz(HeadYaw) · Ry(HeadPitch). The right arm mirrors the left (y → −y).
    """
    k = MODELS[model] if isinstance(model, str) else model
    a = _angles(angles, "fk")
    if a.ndim != 2:
        raise InputError(f"fk: angles must have shape (N, 11), got {a.shape}")
    col = {j: a[:, i] for i, j in enumerate(JOINTS)}
    n = len(a)
    # URDF HipRoll axis is −x: positive HipRoll tilts the torso towards +y (leans to its left).
    torso = axis_rotations(0, -col["HipRoll"])
    out: dict[str, np.ndarray] = {"pelvis": np.zeros((n, 3))}
    for side, sign in (("left", 1.0), ("right", -1.0)):
        s = "L" if side == "left" else "R"
        mirror = np.array([1.0, sign, 1.0])
        shoulder = _apply(torso, np.array(k.shoulder) * mirror)
        bicep = (
            torso
            @ axis_rotations(1, col[f"{s}ShoulderPitch"])
            @ axis_rotations(2, col[f"{s}ShoulderRoll"])
        )
        elbow = shoulder + _apply(bicep, np.array(k.elbow) * mirror)
        fore = (
            bicep
            @ axis_rotations(1, np.full(n, k.elbow_pitch))
            @ axis_rotations(0, col[f"{s}ElbowYaw"])
            @ axis_rotations(2, col[f"{s}ElbowRoll"])
        )
        out[f"{side}_shoulder"] = shoulder
        out[f"{side}_elbow"] = elbow
        out[f"{side}_wrist"] = elbow + _apply(fore, np.array([k.forearm, 0.0, 0.0]))
        out[f"{side}_hip"] = np.broadcast_to(
            np.array([k.shoulder[0], sign * k.hip_half_width, 0.0]), (n, 3)
        ).copy()
    head = _apply(torso, np.array(k.head))
    head_rot = torso @ axis_rotations(2, col["HeadYaw"]) @ axis_rotations(1, col["HeadPitch"])
    out["head"] = head
    for name, offset in FACE_MARKERS.items():
        out[name] = head + _apply(head_rot, np.array(offset))
    return out


def fk_coco17(
    angles: np.ndarray, *, model: Literal["urdf", "ideal"] | Kinematics = "urdf"
) -> np.ndarray:
    """FK as COCO-17 joints `(N, 17, 3)` float64 (knees and ankles NaN), robot frame, metres."""
    from gesturebank.skeletons import COCO17_JOINTS

    pts = fk(angles, model=model)
    n = len(pts["pelvis"])
    nan = np.full((n, 3), np.nan)
    return np.stack([pts.get(j, nan) for j in COCO17_JOINTS], axis=1)
