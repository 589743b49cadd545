"""Retargeting: COCO-17 3D joints `(T, 17, 3)` → Pepper's 11 angles `(T, 11)`
(docs/architecture.md "Contracts").

Same joints, signs and zero pose as the dissertation (seed 000, §3.1), but every angle is a signed
`atan2` in a local frame instead of `acos(|·|)` plus orientation branches, so angles are continuous
and cover their full range.

Body frame (per frame, from the joints only, hence invariant to global rotation, translation and
uniform scale): up = mid-hips → mid-shoulders; left = right → left shoulder, made orthogonal to up;
forward = left × up. The last step needs right-handed input (the contract); the face is not used
to flip it, because a head turned past 90° is a legal pose — `face_forward_fraction` flags takes
that look mirrored. Angles then follow Pepper's joint chains (URDF axes, robot x fwd, y left, z up),
inverted exactly for the arm chain `RetargetConfig.kinematics` names (`pepper.MODELS`): "urdf", the
default, is Pepper's own — the elbow ê = (0.1812, 0.015, 0.00013) m in the bicep frame, 15 mm off
its x axis, and the ElbowYaw frame pitched by β = −9° — so that the robot's upper arm and forearm
point where the person's do and Pepper's own FK poses come back exactly; "ideal" drops both
offsets (ê ∥ x̂, β = 0), a pure pitch-roll-yaw-roll chain.

- ShoulderPitch/Roll: upper arm a ∥ Ry(pitch)·Rz(roll)·ê in the torso frame: Rz(roll)·ê has
  y = a_y and length |a_xz| in xz, so roll = atan2(a_y, wx) − atan2(ê_y, ê_x) with
  wx = √(|a_xz|² − ê_z²), and pitch turns (wx, −ê_z) into (a_x, −a_z) (+π/2 hanging, 0 forward,
  − raised). Ideal chain: roll = atan2(a_y, |a_xz|), pitch = atan2(−a_z, a_x). A person's arm
  hanging straight down is LShoulderRoll −4.7° on the urdf chain (the clamp makes it 0.5°).
- ElbowRoll, ElbowYaw: the forearm in the elbow frame Ry(pitch)·Rz(roll)·Ry(β) is
  g = (cos e, sin e·cos yaw, sin e·sin yaw) (left arm, e = ElbowRoll ≤ 0): ElbowRoll = −∠(g, x̂)
  (0 straight, ∓π/2 at a right angle), ElbowYaw = atan2(−g_z, −g_y) (0 = forearm bends inwards
  in the shoulder's horizontal plane). Pepper's own straight forearm (g = x̂) is `offset` = 10.1°
  off the shoulder → elbow line, so e.g. a hanging arm bent 90° forwards is ElbowRoll ∓81° on
  the urdf chain.
- HeadYaw/Pitch: face direction (mid-ears → mid-eyes) = Rz(yaw)·Ry(pitch)·x̂ in the torso frame.
- Head roll (`head_roll`, no Pepper joint; seeds 002/004 use three head angles): the head is
  turned R = Rz(yaw)·Ry(pitch)·Rx(roll), so its left axis (ear line + eye line) is R·ŷ;
  roll = atan2(lateral·ẑ', lateral·ŷ') with ŷ' = Rz(yaw)·ŷ, ẑ' = Rz(yaw)·Ry(pitch)·ẑ of the same
  yaw and pitch (+ = left ear up, the head tilted towards its right shoulder).
- Head from the face (issue 40): the head's axes (forward, left, up) measured from the face mesh
  (`extract.head_pose`) in the pose's coordinates give the same three angles
  (`head_from_axes`): yaw and pitch from the forward axis, roll from the left axis.
- HipRoll: lean of the torso's up axis along the hip line (left hip − right hip). URDF HipRoll
  turns about −x, so positive = upper body leans to its left, as in the dissertation's code.

Singular set (documented and handled continuously, never by a jump):

- Straight elbow (|ElbowRoll| < `straight_elbow`, default 10°): the arm plane, hence ElbowYaw,
  is undefined, and measured frame by frame it spins (it turns the forearm about its own axis
  and moves nothing). It is held: blended towards its previous frame's value with a weight
  1 − smoothstep(|ElbowRoll|/`straight_elbow`) (`reach.hold_free`), 0 at the start of a take.
  Fading it to 0 instead (as before) made it travel across its range whenever the arm
  straightened (benchmarks/retarget.py measures both).
- Arm that looks straight, urdf chain only (elbow angle < 2·offset ≈ 20°): exactly, a person's
  straight arm would be ElbowRoll −10°, ElbowYaw ≈ +118° (next to the limit), and small bends
  around it cross ElbowYaw ±π, so resting arms would flicker between the yaw limits. Inside this
  band g is shifted (smoothstep, fading out) by the offset, so that a straight arm is Pepper's
  straight arm (ElbowRoll 0, ElbowYaw faded to 0) as on the ideal chain. With 2·offset,
  ElbowRoll is near 0 at the straight arm only (a band narrower than 1.5·offset would bring it
  back to within 2.5° of 0, Pepper's own singular forearm, for one bend direction).
- Arm along the pitch axis (upper arm within `lateral_arm`, default 10°, of it, |a_xz| <
  sin(`lateral_arm`); ideal chain |roll| > 80°, urdf chain roll > 75.3°; e.g. a T-pose): pitch and
  ElbowYaw turn about the same axis, and pitch is ill-conditioned (on the two sides of a T-pose
  it differs by π). Inside this band the pitch is blended (smoothstep) towards the value that
  makes ElbowYaw = 0 given the arm plane (towards 0 when the elbow is straight or folded, or the
  wrist is missing), so the π turn is spread over the band; ElbowYaw is measured in the blended
  frame. The blend can only cancel out, i.e. jump, where the true ElbowYaw is near ±π, beyond
  the robot's limits.
- Branch cuts of atan2 (±π) lie where the robot cannot go: ShoulderPitch ±π (arm pointing straight
  backwards), ElbowYaw ±π, HeadYaw ±π — each the middle of the arc beyond the joint's limits.
  Along a trajectory the angle is continuous across them (`reach.continuous`: the branch nearest
  the previous frame), so an arm raised overhead and behind stays beyond the limit it left from.

Missing joints (NaN) make only the angles that need them NaN: the torso frame needs both shoulders
and hips (all angles), an arm needs its elbow (shoulder angles) and wrist (elbow angles); HeadYaw
needs mid-ears → mid-eyes, else nose and both ears, else the ear or eye line; HeadPitch needs both
eyes and both ears; HipRoll needs the hips and shoulders.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from gesturebank.config import RetargetConfig
from gesturebank.errors import InputError
from gesturebank.geometry import body_frame, cross, dot, unit
from gesturebank.poses import Pose3D
from gesturebank.robot.pepper import JOINTS, MODELS, Kinematics
from gesturebank.robot.reach import continuous, hold_free
from gesturebank.skeletons import COCO17

STRAIGHT_ELBOW = np.deg2rad(10.0)
LATERAL_ARM = np.deg2rad(10.0)

_I = COCO17.index
_USED = COCO17.joints[:13]  # knees and ankles play no part


def pepper_angles(
    pose: Pose3D | np.ndarray,
    *,
    config: RetargetConfig | None = None,
    straight_elbow: float = STRAIGHT_ELBOW,
    lateral_arm: float = LATERAL_ARM,
    free_yaw: Literal["hold", "fade"] = "hold",
) -> np.ndarray:
    """Pepper angles `(T, 11)` float32 radians (order `pepper.JOINTS`) from COCO-17 joints.

    The rows are a trajectory: each angle keeps the branch nearest its previous frame (it may
    leave [−π, π]; `reach.continuous`), and ElbowYaw at a nearly straight elbow is held at its
    previous value (module docstring). Retarget independent poses one at a time.

    pose: a Pose3D, or joints `(T, 17, 3)` in COCO-17 order, right-handed, any unit.
    config: the arm chain inverted (`kinematics`, see the module docstring); None = defaults.
    straight_elbow, lateral_arm: widths (rad) of the singular bands (see the module docstring).
    free_yaw: ElbowYaw at a straight elbow "hold" (its previous value) or "fade" (towards 0, the
    old way, kept for benchmarks/retarget.py's comparison).
    """
    chain = MODELS[(config if config is not None else RetargetConfig()).kinematics]
    p = _points(pose)
    with np.errstate(invalid="ignore", divide="ignore"):
        fwd, left, up = _body_frame(p)

        def local(v: np.ndarray) -> np.ndarray:
            """(3, T) world vector → (3, T) torso-frame components (forward, left, up)."""
            return np.stack([_dot(v, fwd), _dot(v, left), _dot(v, up)])

        mirror = np.array([[1.0], [-1.0], [1.0]])
        l_arm = _arm(
            local(p["left_elbow"] - p["left_shoulder"]),
            local(p["left_wrist"] - p["left_elbow"]),
            straight_elbow,
            lateral_arm,
            chain,
        )
        # The right arm is the left arm mirrored (y → −y): roll, yaw and elbow roll change sign.
        r_arm = _arm(
            mirror * local(p["right_elbow"] - p["right_shoulder"]),
            mirror * local(p["right_wrist"] - p["right_elbow"]),
            straight_elbow,
            lateral_arm,
            chain,
        )
        ears = (p["left_ear"] + p["right_ear"]) / 2
        head_pitch, head_yaw = _head(
            local((p["left_eye"] + p["right_eye"]) / 2 - ears),
            local(p["nose"] - ears),
            local(_head_lateral(p)),
        )
        hip_roll = _hip_roll(up, p["left_hip"] - p["right_hip"])
    out = np.empty((len(up[0]), len(JOINTS)), dtype=np.float32)
    out[:, 0] = head_pitch
    out[:, 1] = head_yaw
    out[:, 2], out[:, 3], out[:, 4] = l_arm[:3]
    out[:, 6], out[:, 7], out[:, 8] = -r_arm[0], r_arm[1], -r_arm[2]
    if free_yaw == "hold":
        out[:, 5], out[:, 9] = hold_free(l_arm[3], l_arm[4]), -hold_free(r_arm[3], r_arm[4])
    else:
        out[:, 5], out[:, 9] = l_arm[3] * l_arm[4], -r_arm[3] * r_arm[4]
    out[:, 10] = hip_roll
    return continuous(out).astype(np.float32)


# The COCO-17 keypoints each angle needs to be *seen* (confidently detected), besides both
# shoulders, which every angle needs. The hips are needed only by HipRoll: with waist-up framing
# the detector still places them, well enough for the torso's up direction, but a lean sideways
# cannot be seen.
_FACE = ("nose", "left_eye", "right_eye")
NEEDS: dict[str, tuple[str, ...]] = {
    "HeadPitch": _FACE,
    "HeadYaw": _FACE,
    "LShoulderRoll": ("left_elbow",),
    "LShoulderPitch": ("left_elbow",),
    "LElbowRoll": ("left_elbow", "left_wrist"),
    "LElbowYaw": ("left_elbow", "left_wrist"),
    "RShoulderRoll": ("right_elbow",),
    "RShoulderPitch": ("right_elbow",),
    "RElbowRoll": ("right_elbow", "right_wrist"),
    "RElbowYaw": ("right_elbow", "right_wrist"),
    "HipRoll": ("left_hip", "right_hip"),
}


def angle_support(valid: np.ndarray) -> np.ndarray:
    """`(T, 11)` bool: the angle's keypoints were seen, from `valid (T, 17)` COCO-17 bools.

    An angle whose keypoints were not seen (occluded, out of frame) is masked instead of
    guessed from the detector's extrapolation (see `NEEDS`)."""
    v = np.asarray(valid, dtype=bool)
    torso = v[:, _I["left_shoulder"]] & v[:, _I["right_shoulder"]]
    return np.stack([torso & v[:, [_I[k] for k in NEEDS[j]]].all(axis=1) for j in JOINTS], axis=1)


def face_forward_fraction(pose: Pose3D | np.ndarray) -> float:
    """Fraction of frames whose face (mid-ears → nose) points in front of the torso, in [0, 1].

    Near 1 for right-handed input with correct left/right labels; near 0 means the input is
    mirrored (left-handed) or its left/right labels are swapped. NaN if no frame has a face.
    """
    p = _points(pose)
    with np.errstate(invalid="ignore", divide="ignore"):
        fwd = _body_frame(p)[0]
        ahead = _dot(fwd, p["nose"] - (p["left_ear"] + p["right_ear"]) / 2)
    ok = np.isfinite(ahead)
    return float(np.mean(ahead[ok] > 0)) if ok.any() else float("nan")


def _points(pose: Pose3D | np.ndarray) -> dict[str, np.ndarray]:
    """Joint name → (3, T) float64 coordinates (components as rows: fast elementwise maths)."""
    j = pose.joints if isinstance(pose, Pose3D) else np.asarray(pose)
    if j.ndim != 3 or j.shape[1:] != (len(COCO17), 3):
        raise InputError(
            f"pepper_angles: joints must have shape (T, 17, 3) in COCO-17 order, got {j.shape}"
        )
    if not np.issubdtype(j.dtype, np.number):
        raise InputError(f"pepper_angles: joints must be numeric, got dtype {j.dtype}")
    soa = np.ascontiguousarray(j[:, : len(_USED)].transpose(1, 2, 0), dtype=np.float64)
    return {name: soa[i] for i, name in enumerate(_USED)}


# Vectors are (3, T) arrays: row k is component k over all frames.
def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return dot(a, b, axis=0)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return cross(a, b, axis=0)


def _unit(v: np.ndarray) -> np.ndarray:
    return unit(v, axis=0)


def _body_frame(p: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Torso axes (forward, left, up), each (3, T) unit: the body frame of `geometry`."""
    return body_frame(
        p["left_shoulder"],
        p["right_shoulder"],
        left_hip=p["left_hip"],
        right_hip=p["right_hip"],
        axis=0,
    )


def _smoothstep(x: np.ndarray) -> np.ndarray:
    t = np.clip(x, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _arm(
    upper: np.ndarray, fore: np.ndarray, straight_elbow: float, lateral_arm: float, k: Kinematics
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Left-arm angles (roll, pitch, elbow roll, elbow yaw) and the weight in [0, 1] of the
    measured elbow yaw against its previous value (0 at a straight elbow), each (T,), from
    torso-frame vectors.

    upper: (3, T) shoulder → elbow; fore: (3, T) elbow → wrist; k: the arm chain inverted.
    """
    ex, ey, ez = np.asarray(k.elbow) / np.linalg.norm(k.elbow)  # elbow in the bicep frame
    cb, sb = np.cos(k.elbow_pitch), np.sin(k.elbow_pitch)
    a, b = _unit(upper), _unit(fore)
    ax, ay, az = a
    cos_roll = np.hypot(ax, az)  # distance of the upper arm from the pitch axis
    # a = Ry(pitch)·w, w = Rz(roll)·ê = (wx, a_y, ez): roll + atan2(ey, ex) = atan2(a_y, wx).
    wx = np.sqrt(np.clip(cos_roll * cos_roll - ez * ez, 0.0, None))
    roll = np.arctan2(ay, wx) - np.arctan2(ey, ex)
    # Pitch turns (wx, −ez) into (a_x, −a_z): (pc, ps) = (a_x, −a_z) turned back by w's own
    # angle, length |a_xz| (ideal chain: ez = 0, (pc, ps) = (a_x, −a_z)).
    h = np.hypot(wx, ez)
    h = np.where(h > 0, h, 1.0)
    pc, ps = (ax * wx + az * ez) / h, (ax * ez - az * wx) / h
    # Arm plane normal b × a (length sin(angle)): the bicep z axis when ElbowYaw = 0 (ideal arm).
    n = _cross(b, a)
    elbow_angle = np.arctan2(np.sqrt(_dot(n, n)), _dot(a, b))  # 0 = the arm looks straight
    # Inside the lateral band, blend in the bicep z axis (sin, 0, cos)(pitch) implied by the arm
    # plane, or pitch 0 where there is no arm plane (elbow straight or folded, wrist missing).
    # The blend can only cancel out where the true ElbowYaw is near ±π, beyond the robot's limits.
    w = 1.0 - _smoothstep(cos_roll / np.sin(lateral_arm))
    n = np.where(np.isfinite(n), n, 0.0)
    no_plane = 1.0 - _smoothstep(np.sqrt(_dot(n, n)) / np.sin(straight_elbow))
    pitch = np.arctan2(ps + w * n[0], pc + w * (n[2] + no_plane))
    cp, sp, cr, sr = np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
    # Forearm f in the bicep frame Ry(pitch)·Rz(roll), then g in the elbow frame f·Ry(elbow_pitch).
    fx = cr * cp * b[0] + sr * b[1] - cr * sp * b[2]
    fy = -sr * cp * b[0] + cr * b[1] + sr * sp * b[2]
    fz = sp * b[0] + cp * b[2]
    gx, gz = cb * fx - sb * fz, sb * fx + cb * fz
    # An arm that looks straight is the chain's straight arm: up to an elbow angle of 2·offset,
    # shift g from the shoulder → elbow line towards x̂ (module docstring; ideal: offset = 0).
    line = (cb * ex - sb * ez, ey, sb * ex + cb * ez)  # ê in the elbow frame
    offset = np.arctan2(np.hypot(line[1], line[2]), line[0])
    if offset > 0:
        keep = 1.0 - _smoothstep(elbow_angle / (2.0 * offset))
        gx, fy, gz = gx + keep * (1.0 - line[0]), fy - keep * line[1], gz - keep * line[2]
    # Left arm: g = (cos e, sin e·cos yaw, sin e·sin yaw) with e = ElbowRoll = −bend ≤ 0.
    bend = np.arctan2(np.hypot(fy, gz), gx)
    yaw = np.arctan2(-gz, -fy)
    return roll, pitch, -bend, yaw, _smoothstep(bend / straight_elbow)


def _head_lateral(p: dict[str, np.ndarray]) -> np.ndarray:
    """(3, T) head's left axis from the ear line plus the eye line (whichever exist), else NaN."""
    ears = p["left_ear"] - p["right_ear"]
    eyes = p["left_eye"] - p["right_eye"]
    ears_ok, eyes_ok = np.isfinite(ears), np.isfinite(eyes)
    lateral = np.where(ears_ok, ears, 0.0) + np.where(eyes_ok, eyes, 0.0)
    return np.where(ears_ok | eyes_ok, lateral, np.nan)


def _head(face: np.ndarray, nose: np.ndarray, lateral: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(HeadPitch, HeadYaw), each (T,), from torso-frame head vectors (3, T).

    face: mid-ears → mid-eyes (= Rz(yaw)·Ry(pitch)·x̂ up to scale); nose: mid-ears → nose (in the
    mid-sagittal plane: its heading is the yaw, its elevation is not the pitch); lateral: head's
    left axis (= Rz(yaw)·ŷ, pitch turns about it).
    """
    # Yaw from the best heading available; a level heading ⟂ the lateral axis as the last resort.
    level = np.stack([lateral[1], -lateral[0]])
    hx = np.where(np.isfinite(face[0]), face[0], np.where(np.isfinite(nose[0]), nose[0], level[0]))
    hy = np.where(np.isfinite(face[0]), face[1], np.where(np.isfinite(nose[0]), nose[1], level[1]))
    yaw = np.arctan2(hy, hx)
    pitch = np.arctan2(-face[2], np.hypot(face[0], face[1]))  # + = face down
    return pitch, yaw


def head_roll(pose: Pose3D | np.ndarray) -> np.ndarray:
    """The head's roll `(T,)` float32 rad from COCO-17 joints `(T, 17, 3)` (module docstring):
    yaw and pitch as `pepper_angles` measures them (face direction, then the head's lateral
    axis turned about it). NaN where the face direction, the ears or the eyes are missing."""
    p = _points(pose)
    with np.errstate(invalid="ignore", divide="ignore"):
        fwd, left, up = _body_frame(p)

        def local(v: np.ndarray) -> np.ndarray:
            return np.stack([_dot(v, fwd), _dot(v, left), _dot(v, up)])

        ears = (p["left_ear"] + p["right_ear"]) / 2
        face = local((p["left_eye"] + p["right_eye"]) / 2 - ears)
        lateral = local(_head_lateral(p))
        pitch, yaw = _head(face, local(p["nose"] - ears), lateral)
        roll = _head_roll(lateral, pitch, yaw)
    return roll.astype(np.float32)


def head_from_axes(pose: Pose3D | np.ndarray, axes: np.ndarray) -> np.ndarray:
    """`(T, 3)` float32 rad (HeadPitch, HeadYaw, head_roll) of a head whose axes `axes
    (T, 3, 3)` (columns forward, left, up, in the coordinates of `pose`'s joints) are known,
    relative to the torso of `pose`, as `pepper_angles` and `head_roll` define them (module
    docstring). NaN where the axes or the torso are missing."""
    p = _points(pose)
    a = np.asarray(axes, np.float64)
    if a.shape != (len(p["nose"][0]), 3, 3):
        raise InputError(f"head_from_axes: axes must be ({len(p['nose'][0])}, 3, 3), got {a.shape}")
    with np.errstate(invalid="ignore", divide="ignore"):
        fwd, left, up = _body_frame(p)

        def local(v: np.ndarray) -> np.ndarray:
            return np.stack([_dot(v, fwd), _dot(v, left), _dot(v, up)])

        face, lateral = local(a[:, :, 0].T), local(a[:, :, 1].T)
        pitch, yaw = _head(face, np.full_like(face, np.nan), lateral)
        roll = _head_roll(lateral, pitch, yaw)
        pitch = np.where(np.isfinite(face[0]), pitch, np.nan)
        yaw = np.where(np.isfinite(face[0]), yaw, np.nan)
    return np.stack([pitch, yaw, roll], axis=1).astype(np.float32)


def _head_roll(lateral: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """(T,) roll of the head's left axis `lateral` (3, T) about its forward axis, given its
    (pitch, yaw): the angle from ŷ' = Rz(yaw)·ŷ towards ẑ' = Rz(yaw)·Ry(pitch)·ẑ."""
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    y_axis = np.stack([-sy, cy, np.zeros_like(cy)])
    z_axis = np.stack([cy * sp, sy * sp, cp])  # Rz(yaw)·Ry(pitch)·ẑ, + pitch = face down
    return np.arctan2(_dot(lateral, z_axis), _dot(lateral, y_axis))


def _hip_roll(up: np.ndarray, hips: np.ndarray) -> np.ndarray:
    """(T,) lean of the torso's up axis (3, T) towards the left hip (hips: right → left hip)."""
    s = _dot(up, _unit(hips))
    return np.arctan2(s, np.sqrt(np.clip(1.0 - s * s, 0.0, None)))
