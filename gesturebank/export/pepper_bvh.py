"""Pepper's upper body as a BVH skeleton, driven by the 11 angles (Blender, the GENEA visualiser).

Offsets are those of the robot profile's kinematic chain (`pepper.MODELS`), in centimetres.
BVH axes: x = the robot's left, y = up, z = forward (robot frame x fwd, y left, z up; a proper
rotation, so right-handed stays right-handed). A robot rotation about its x, y, z axis is a BVH
Zrotation, Xrotation, Yrotation. Each joint's channels reproduce `pepper.fk` exactly:

    Hip (root, fixed; its children LHip/RHip are the virtual hip markers)
      Torso      Zrotation = −HipRoll                     (URDF HipRoll turns about −x)
        Head     Yrotation = HeadYaw, Xrotation = HeadPitch
        LShoulder Xrotation = ShoulderPitch, Yrotation = ShoulderRoll
          LElbow Xrotation = the fixed elbow pitch, Zrotation = ElbowYaw, Yrotation = ElbowRoll
            LWrist (WristYaw, not controlled: 0)

Angles are written in degrees as BVH wants; `mocap.names` maps these joint names back.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from gesturebank.mocap.bvh import Motion
from gesturebank.robot.pepper import JOINTS, MODELS, Kinematics

CM = 100.0  # BVH offsets in centimetres, the unit most BVH files use
HAND_M = 0.05  # end site beyond the wrist (drawn only), metres
HEAD_TOP_M = 0.2  # end site above the head joint (drawn only), metres
HIP_DROP_M = 0.1  # end site below the virtual hips (drawn only), metres


def _bvh(v: tuple[float, float, float] | np.ndarray) -> list[float]:
    """Robot (x fwd, y left, z up) metres → BVH (x left, y up, z fwd) centimetres."""
    return [CM * float(v[1]), CM * float(v[2]), CM * float(v[0])]


def pepper_motion(
    *,
    angles: np.ndarray,
    frame_time: float,
    kinematics: Literal["urdf", "ideal"] | Kinematics,
) -> Motion:
    """The Motion of Pepper playing `angles (N, 11)` rad (`JOINTS` order, finite) every
    `frame_time` seconds."""
    k = MODELS[kinematics] if isinstance(kinematics, str) else kinematics
    a = np.rad2deg(np.asarray(angles, dtype=np.float64))
    col = {j: a[:, i] for i, j in enumerate(JOINTS)}
    zero = np.zeros(len(a))
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[tuple[str, ...]] = []
    ends: list[bool] = []
    values: list[np.ndarray] = []
    rot3 = ("Zrotation", "Xrotation", "Yrotation")

    def joint(
        name: str,
        parent: int,
        offset: list[float],
        chans: tuple[str, ...],
        vals: tuple[np.ndarray, ...],
        end: list[float] | None = None,
    ) -> int:
        names.append(name)
        parents.append(parent)
        offsets.append(offset)
        channels.append(chans)
        ends.append(False)
        values.extend(vals)
        me = len(names) - 1
        if end is not None:
            names.append(f"{name}_End")
            parents.append(me)
            offsets.append(end)
            channels.append(())
            ends.append(True)
        return me

    hip = joint(
        "Hip", -1, [0.0, 0.0, 0.0], ("Xposition", "Yposition", "Zposition", *rot3), (zero,) * 6
    )
    for s, sign in (("L", 1.0), ("R", -1.0)):
        joint(
            f"{s}Hip",
            hip,
            _bvh((k.shoulder[0], sign * k.hip_half_width, 0.0)),
            rot3,
            (zero,) * 3,
            end=_bvh((0.0, 0.0, -HIP_DROP_M)),
        )
    torso = joint("Torso", hip, [0.0, 0.0, 0.0], rot3, (-col["HipRoll"], zero, zero))
    joint(
        "Head",
        torso,
        _bvh(k.head),
        ("Yrotation", "Xrotation", "Zrotation"),
        (col["HeadYaw"], col["HeadPitch"], zero),
        end=_bvh((0.0, 0.0, HEAD_TOP_M)),
    )
    beta = np.full(len(a), np.rad2deg(k.elbow_pitch))
    for s, sign in (("L", 1.0), ("R", -1.0)):
        mirror = np.array([1.0, sign, 1.0])
        sh = joint(
            f"{s}Shoulder",
            torso,
            _bvh(np.array(k.shoulder) * mirror),
            ("Xrotation", "Yrotation", "Zrotation"),
            (col[f"{s}ShoulderPitch"], col[f"{s}ShoulderRoll"], zero),
        )
        el = joint(
            f"{s}Elbow",
            sh,
            _bvh(np.array(k.elbow) * mirror),
            ("Xrotation", "Zrotation", "Yrotation"),
            (beta, col[f"{s}ElbowYaw"], col[f"{s}ElbowRoll"]),
        )
        joint(
            f"{s}Wrist",
            el,
            _bvh((k.forearm, 0.0, 0.0)),
            rot3,
            (zero,) * 3,
            end=_bvh((HAND_M, 0.0, 0.0)),
        )
    return Motion(
        tuple(names),
        tuple(parents),
        np.array(offsets),
        tuple(channels),
        tuple(ends),
        np.stack(values, axis=1) if values else np.zeros((len(a), 0)),
        frame_time,
    )
