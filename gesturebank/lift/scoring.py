"""Scoring a monocular lifter against known 3D truth, from the true joints seen by a pinhole.

The perfect-detector yardstick of benchmarks/fidelity.py and the lifter tests: known 3D joints
(motion capture, metres, any right-handed world frame) are projected by a `Camera` into a COCO-17
`Pose2D` (every keypoint confident), a lifter lifts that view, and the result is scored in
robot space, where it matters:

- per Pepper joint, the angle error of the retargeted lift against the retargeted truth (°);
- per arm bone, the depth sign: of the frames where the true bone's component along the camera
  ray through its parent joint exceeds `DEEP` of its length, the share where the lifted bone
  points the other way along that ray;
- Pepper's forward kinematics on both sets of angles: elbow and hand (WristYaw) distance, cm;
- the head's direction (HeadYaw, HeadPitch as a unit vector) error, °, and the signed mean
  error of HeadPitch and HeadYaw (`head_bias_deg`): a constant offset (a definition or
  convention mismatch) shows there, while noise averages out.

Mirror consistency is measured with `mirror_view` (the image flipped left-right, the left and
right keypoints exchanged) and `mirror_angles` (the robot's angles of the mirrored motion turned
back). Lifters output different frames; `camera_axes` turns each into the camera's axes (x right,
y down, z forward).

Oracles (issue 39's floors, benchmarks/heldout.py --floors) set one thing a lift cannot see in
its image true: the arm bones' depth signs, the torso's tilt towards the camera, or every
joint's depth on its 2D ray. Two lifts of one view (the net's and BlazePose's world landmarks)
are combined bone by bone by `averaged_directions`, and by the oracle `with_nearer_directions`,
the ceiling of any choice between them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gesturebank.camera_files import Camera
from gesturebank.config import RetargetConfig
from gesturebank.poses import Pose2D, Pose3D
from gesturebank.robot.pepper import JOINTS, fk
from gesturebank.robot.retarget import pepper_angles
from gesturebank.skeletons import COCO17

DEEP = 0.3  # a bone points clearly towards or away from the camera beyond this share of its length
ARM_BONES = {
    f"{side[0].upper()} {part}": (COCO17.index[f"{side}_{a}"], COCO17.index[f"{side}_{b}"])
    for side in ("left", "right")
    for part, (a, b) in (("upper arm", ("shoulder", "elbow")), ("forearm", ("elbow", "wrist")))
}
ARM_JOINTS = [j for j, name in enumerate(JOINTS) if "Shoulder" in name or "Elbow" in name]
# Output frames of the lifters → camera axes (x right, y down, z forward): a diagonal flip.
AXES = {
    "camera": (1.0, 1.0, 1.0),
    "blazepose-world": (1.0, 1.0, 1.0),
    "image-ortho": (1.0, -1.0, -1.0),
}
# (J,) COCO-17 index of each joint's mirror image (itself for the nose).
MIRROR = np.array(
    [
        COCO17.index[n.replace("left", "right") if "left" in n else n.replace("right", "left")]
        for n in COCO17.joints
    ]
)
# Pepper angles of a mirrored motion: left and right exchanged, rolls and yaws negated.
_ANGLE_SOURCE = [JOINTS.index({"L": "R", "R": "L"}.get(j[0], j[0]) + j[1:]) for j in JOINTS]
_ANGLE_SIGN = np.array([-1.0 if ("Roll" in j or "Yaw" in j) else 1.0 for j in JOINTS])


@dataclass(frozen=True, eq=False)
class LiftScore:
    """One lift against the truth.

    angle_error_deg: (11,) mean |error| per Pepper joint (order `pepper.JOINTS`), degrees.
    signs: arm bone → (frames where the true bone is deep, of those the frames lifted wrong).
    elbow_cm, hand_cm: mean Pepper-FK distance over both sides and all frames, cm.
    head_deg: mean angle between the lifted and the true head direction, degrees.
    head_bias: mean signed HeadPitch and HeadYaw error, degrees (`head_bias_deg`).
    """

    angle_error_deg: np.ndarray
    signs: dict[str, tuple[int, int]]
    elbow_cm: float
    hand_cm: float
    head_deg: float
    head_bias: tuple[float, float]

    @property
    def arm_mae_deg(self) -> float:
        """Mean angle error over the eight arm joints, degrees."""
        return float(np.nanmean(self.angle_error_deg[ARM_JOINTS]))

    @property
    def wrong_sign_pct(self) -> float:
        """Pooled share of deep arm-bone frames lifted with the wrong depth sign, %."""
        deep = sum(n for n, _ in self.signs.values())
        return 100.0 * sum(w for _, w in self.signs.values()) / max(deep, 1)


def look_at(
    *, eye: np.ndarray, target: np.ndarray, up: np.ndarray, size: tuple[int, int], fov_deg: float
) -> Camera:
    """A distortion-free pinhole camera at `eye` looking at `target`, image `up` along the
    world's `up`, principal point at the image centre, `fov_deg` across the width."""
    forward = np.asarray(target, float) - np.asarray(eye, float)
    forward /= np.linalg.norm(forward)
    down = -(np.asarray(up, float) - (np.asarray(up, float) @ forward) * forward)
    down /= np.linalg.norm(down)
    rot = np.stack([np.cross(down, forward), down, forward])  # rows: x right, y down, z forward
    focal = 0.5 * size[0] / np.tan(np.deg2rad(fov_deg) / 2)
    K = np.array([[focal, 0.0, size[0] / 2], [0.0, focal, size[1] / 2], [0.0, 0.0, 1.0]])
    return Camera("truth", size, K, np.zeros(0), rot, -rot @ np.asarray(eye, float))


def project_view(joints: np.ndarray, camera: Camera, *, timestamps: np.ndarray) -> Pose2D:
    """COCO-17 Pose2D of world joints (T, 17, 3): their pixels, confidence 1 (NaN if missing)."""
    xy = camera.project(np.asarray(joints, np.float64))
    conf = np.where(np.isfinite(xy).all(axis=-1), 1.0, np.nan)
    return Pose2D(np.concatenate([xy, conf[..., None]], -1), timestamps, COCO17.name, camera.size)


def mirror_view(pose2d: Pose2D) -> Pose2D:
    """The view flipped left-right (x → width − x) with left and right keypoints exchanged: the
    2D of the mirrored person (a camera with its principal point at the centre is unchanged)."""
    coco = pose2d.to_coco17()
    kp = coco.keypoints[:, MIRROR].copy()
    kp[..., 0] = coco.image_size[0] - kp[..., 0]
    world = None
    if coco.world is not None:
        world = coco.world[:, MIRROR].copy()
        world[..., 0] *= -1
    return Pose2D(kp, coco.timestamps, COCO17.name, coco.image_size, world)


def mirror_angles(angles: np.ndarray) -> np.ndarray:
    """(T, 11) Pepper angles of the mirror image of the motion with angles (T, 11)."""
    return np.asarray(angles)[:, _ANGLE_SOURCE] * _ANGLE_SIGN


def camera_axes(pose: Pose3D) -> np.ndarray:
    """(T, 17, 3) float64 joints of a lifter's output in camera axes (x right, y down, z fwd)."""
    return pose.joints.astype(np.float64) * np.asarray(AXES.get(pose.frame, (1.0, 1.0, 1.0)))


def angle_error_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """|a − b| in degrees, periodic; NaN where either is unknown."""
    d = np.abs(np.asarray(a, np.float64) - np.asarray(b, np.float64)) % (2 * np.pi)
    return np.rad2deg(np.minimum(d, 2 * np.pi - d))


def sign_errors(
    lifted: np.ndarray, truth: np.ndarray, *, camera: Camera
) -> dict[str, tuple[int, int]]:
    """Arm bone → (deep frames, wrong frames): lifted joints (T, 17, 3) in camera axes against
    world truth (T, 17, 3) seen by `camera` (module docstring)."""
    true_cam = camera.to_camera(truth)
    out = {}
    for name, (i, j) in ARM_BONES.items():
        ray = true_cam[:, i] / np.linalg.norm(true_cam[:, i], axis=-1, keepdims=True)
        bone = true_cam[:, j] - true_cam[:, i]
        with np.errstate(invalid="ignore"):
            along = np.sum(bone * ray, -1) / np.linalg.norm(bone, axis=-1)
            mine = np.sum((lifted[:, j] - lifted[:, i]) * ray, -1)
            deep = (np.abs(along) > DEEP) & np.isfinite(mine)
        out[name] = (int(deep.sum()), int((np.sign(mine[deep]) != np.sign(along[deep])).sum()))
    return out


def head_direction(angles: np.ndarray) -> np.ndarray:
    """(T, 3) unit face direction Rz(HeadYaw)·Ry(HeadPitch)·x̂ in the torso frame."""
    pitch, yaw = angles[:, JOINTS.index("HeadPitch")], angles[:, JOINTS.index("HeadYaw")]
    return np.stack([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), -np.sin(pitch)], 1)


def head_bias_deg(angles: np.ndarray, truth_angles: np.ndarray) -> tuple[float, float]:
    """Mean signed error (°) of HeadPitch and HeadYaw (yaw wrapped to ±180°), angles (T, 11)
    against the true ones, over the frames where both are known."""
    out = []
    for joint in ("HeadPitch", "HeadYaw"):
        k = JOINTS.index(joint)
        d = np.asarray(angles, np.float64)[:, k] - np.asarray(truth_angles, np.float64)[:, k]
        d = ((d + np.pi) % (2 * np.pi) - np.pi)[np.isfinite(d)]
        out.append(float(np.rad2deg(d.mean())) if len(d) else float("nan"))
    return out[0], out[1]


def score_angles(
    angles: np.ndarray, truth_angles: np.ndarray
) -> tuple[np.ndarray, float, float, float]:
    """Angle error per joint (11,) °, FK elbow and hand error cm, head direction error ° of
    Pepper angles (T, 11) against the true ones (T, 11)."""
    with np.errstate(invalid="ignore"):
        per_joint = np.nanmean(angle_error_deg(angles, truth_angles), axis=0)
        mine, true = fk(np.nan_to_num(angles)), fk(np.nan_to_num(truth_angles))
        known = np.isfinite(angles).all(axis=1) & np.isfinite(truth_angles).all(axis=1)
        dist = {
            part: np.mean([
                np.linalg.norm(mine[f"{s}_{part}"] - true[f"{s}_{part}"], axis=1)[known]
                for s in ("left", "right")
            ])
            for part in ("elbow", "wrist")
        }  # fmt: skip
        cos = np.sum(head_direction(angles) * head_direction(truth_angles), axis=1)
        head = np.nanmean(np.rad2deg(np.arccos(np.clip(cos, -1, 1))))
    return per_joint, 100 * float(dist["elbow"]), 100 * float(dist["wrist"]), float(head)


def score_lift(
    lifted: Pose3D, truth: np.ndarray, *, camera: Camera, retarget: RetargetConfig
) -> LiftScore:
    """Score one lift (any lifter's output frame) of `camera`'s view of world joints `truth`
    (T, 17, 3), through the retargeting `retarget`."""
    joints = camera_axes(lifted)
    angles = pepper_angles(joints, config=retarget)
    true_angles = pepper_angles(truth, config=retarget)
    per_joint, elbow, hand, head = score_angles(angles, true_angles)
    signs = sign_errors(joints, truth, camera=camera)
    return LiftScore(per_joint, signs, elbow, hand, head, head_bias_deg(angles, true_angles))


# Oracles (issue 39's floors): the lift with one thing it cannot see in the image set true, so
# the error that remains says how much of the error that thing is.


def with_true_depth_signs(lifted: np.ndarray, truth_camera: np.ndarray) -> np.ndarray:
    """Lifted joints (T, 17, 3), camera axes, with each arm bone whose direction along the
    camera ray through its parent disagrees in sign with the truth (T, 17, 3, camera axes)
    reflected across the plane normal to that ray (its image nearly unchanged), the joints
    below it carried along: the lift with the frontal ambiguity resolved right."""
    out = np.array(lifted, dtype=np.float64)
    for side in ("left", "right"):
        s, e, w = (COCO17.index[f"{side}_{j}"] for j in ("shoulder", "elbow", "wrist"))
        for parent, child, carried in ((s, e, [e, w]), (e, w, [w])):
            ray = truth_camera[:, parent] / np.linalg.norm(truth_camera[:, parent], axis=-1,
                                                           keepdims=True)  # fmt: skip
            mine = np.sum((out[:, child] - out[:, parent]) * ray, -1)
            true = np.sum((truth_camera[:, child] - truth_camera[:, parent]) * ray, -1)
            wrong = np.flatnonzero(np.isfinite(mine + true) & (np.sign(mine) != np.sign(true)))
            out[np.ix_(wrong, np.asarray(carried))] -= (
                2.0 * (mine[wrong, None] * ray[wrong])[:, None]
            )
    return out


def at_true_depth(keypoints: np.ndarray, *, camera: Camera, truth_camera: np.ndarray) -> np.ndarray:
    """(T, 17, 3) camera axes: each joint on the ray through its pixel (keypoints (T, 17, ≥2)
    of `camera`) at the true joint's depth (truth_camera (T, 17, 3)): what a lifter that knew
    every depth would make of this 2D, so its error is the 2D's alone (none for the true 2D)."""
    rays = camera.undistort_points(np.asarray(keypoints, np.float64)[..., :2], normalised=True)
    depth = truth_camera[..., 2:3]
    return np.concatenate([rays * depth, depth], axis=-1)


def torso_tilt_deg(joints: np.ndarray) -> np.ndarray:
    """(T,) the torso's tilt away from the camera, degrees, of joints (T, 17, 3) in camera axes
    (x right, y down, z forward): mid-hip → neck in the y–z plane, 0 upright, + the top away."""
    spine = joints[:, [5, 6]].mean(axis=1) - joints[:, [11, 12]].mean(axis=1)
    return np.asarray(np.rad2deg(np.arctan2(spine[:, 2], -spine[:, 1])))


def with_true_tilt(lifted: np.ndarray, truth_camera: np.ndarray) -> np.ndarray:
    """Lifted joints (T, 17, 3), camera axes, with the hips (and legs) turned per frame about the
    camera's x axis through the neck so the torso's tilt (`torso_tilt_deg`) is the truth's (T,
    17, 3, camera axes), the arms and face kept as lifted (turning the whole body would change
    no robot angle)."""
    out = np.array(lifted, dtype=np.float64)
    turn = np.deg2rad(torso_tilt_deg(truth_camera) - torso_tilt_deg(out))[:, None]
    neck = out[:, [5, 6]].mean(axis=1, keepdims=True)
    rel = out[:, 11:] - neck
    up, away = -rel[..., 1], rel[..., 2]  # the tilt turns (up, away) by `turn`
    rel[..., 1] = -(up * np.cos(turn) - away * np.sin(turn))
    rel[..., 2] = up * np.sin(turn) + away * np.cos(turn)
    out[:, 11:] = neck + rel
    return out


# Two lifts of one view combined bone by bone (issue 39: BlazePose's world landmarks as a second
# input), the net's bone lengths kept: each bone (parent, child) from the neck (None) outwards.
_I = COCO17.index
_BONES = (
    *((None, _I[j]) for j in ("left_shoulder", "right_shoulder", "left_hip", "right_hip", "nose")),
    *((_I["nose"], _I[f"{s}_eye"]) for s in ("left", "right")),
    *((_I[f"{s}_eye"], _I[f"{s}_ear"]) for s in ("left", "right")),
    *((_I[f"{s}_{a}"], _I[f"{s}_{b}"]) for s in ("left", "right")
      for a, b in (("shoulder", "elbow"), ("elbow", "wrist"))),
)  # fmt: skip


def _units(joints: np.ndarray) -> list[np.ndarray]:
    """(T, 3) unit direction of each bone of `_BONES` in joints (T, 17, 3)."""
    neck = joints[:, [5, 6]].mean(axis=1)
    out = []
    for parent, child in _BONES:
        bone = joints[:, child] - (neck if parent is None else joints[:, parent])
        with np.errstate(invalid="ignore", divide="ignore"):
            out.append(bone / np.linalg.norm(bone, axis=-1, keepdims=True))
    return out


def _rebuilt(lifted: np.ndarray, units: list[np.ndarray]) -> np.ndarray:
    """lifted (T, 17, 3) rebuilt from its neck with its own bone lengths along `units`."""
    out = np.array(lifted, dtype=np.float64)
    neck = out[:, [5, 6]].mean(axis=1)
    for (parent, child), unit in zip(_BONES, units, strict=True):
        start = neck if parent is None else out[:, parent]
        length = np.linalg.norm(lifted[:, child] - (neck if parent is None
                                                    else lifted[:, parent]), axis=-1)  # fmt: skip
        out[:, child] = start + length[:, None] * unit
    return out


def averaged_directions(lifted: np.ndarray, other: np.ndarray, *, weight: float) -> np.ndarray:
    """lifted (T, 17, 3, camera axes) with each bone along `weight` × its direction + (1 −
    `weight`) × `other`'s (T, 17, 3, camera axes, any origin), normalised; where `other` lacks
    the bone, lifted's own."""
    units = []
    for mine, theirs in zip(_units(lifted), _units(other), strict=True):
        known = np.isfinite(theirs).all(axis=-1, keepdims=True)
        mix = np.where(known, weight * mine + (1 - weight) * np.nan_to_num(theirs), mine)
        units.append(mix / np.linalg.norm(mix, axis=-1, keepdims=True))
    return _rebuilt(lifted, units)


def with_nearer_directions(
    lifted: np.ndarray, other: np.ndarray, *, truth_camera: np.ndarray
) -> np.ndarray:
    """An oracle: lifted (T, 17, 3, camera axes) with each bone, per frame, along whichever of its
    own and `other`'s direction is nearer the truth's (T, 17, 3, camera axes): the best a choice
    between the two lifts could do."""
    units = []
    for mine, theirs, true in zip(_units(lifted), _units(other), _units(truth_camera),
                                  strict=True):  # fmt: skip
        nearer = np.nan_to_num(np.sum(theirs * true, -1), nan=-2.0) > np.nan_to_num(
            np.sum(mine * true, -1), nan=-2.0
        )
        units.append(np.where(nearer[:, None], theirs, mine))
    return _rebuilt(lifted, units)
