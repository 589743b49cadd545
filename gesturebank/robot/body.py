"""Pepper's look: the robot as shaded primitives (spheres, capped cones/cylinders, boxes) placed
on the points of `pepper.fk`, for `render3d`.

Each part is a unit shape (sphere of radius 1; cone frustum along z from −1 to 1; box [−1, 1]³)
mapped into the robot frame (metres, x forward, y left, z up, origin at the HipRoll pivot) by an
affine matrix. The moving parts sit on FK points (shoulders, elbows, wrists, face markers), so
the picture is the kinematic model; the sizes are Pepper's, by eye from its published drawings
(1.21 m tall, base about 0.48 m wide). The leg and the wheeled base do not move (Pepper's
HipPitch and KneePitch are not among the 11 joints), so `static_parts` is rendered once.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

Kind = Literal["sphere", "cone", "box"]
RGB = tuple[float, float, float]

GROUND_Z = -0.82  # floor under the wheels, robot frame (the HipRoll pivot is at 0)
TOP_Z = 0.42  # top of the head at rest
WHITE, GREY, DARK, BLACK = (0.93, 0.93, 0.92), (0.62, 0.63, 0.65), (0.22, 0.23, 0.25), (0.06,) * 3
SCREEN, EYE_LED = (0.10, 0.16, 0.24), (0.55, 0.85, 1.0)


@dataclass(frozen=True, eq=False)
class Part:
    """A unit shape mapped by `x_world = matrix[:3, :3] @ x_unit + matrix[:3, 3]`.

    colour: linear RGB in [0, 1]; r0, r1: a cone's radii at z = −1 and z = 1 (1, 1: a cylinder);
    glow: drawn unshaded (LEDs, a lit screen).
    """

    kind: Kind
    matrix: np.ndarray
    colour: RGB
    r0: float = 1.0
    r1: float = 1.0
    glow: bool = False


def _affine(rot: np.ndarray, scale: tuple[float, float, float], at: np.ndarray) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rot @ np.diag(scale)
    m[:3, 3] = at
    return m


def _frame_along(axis: np.ndarray, up: np.ndarray) -> np.ndarray:
    """A rotation whose z column is `axis` (normalised) and whose x column is near `up`."""
    z = axis / max(float(np.linalg.norm(axis)), 1e-9)
    x = up - np.dot(up, z) * z
    if np.linalg.norm(x) < 1e-6:  # `up` along the axis: any perpendicular will do
        x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], axis=1)


def _segment(
    a: np.ndarray, b: np.ndarray, r_a: float, r_b: float, colour: RGB, up: np.ndarray
) -> Part:
    """A capped cone from `a` (radius r_a) to `b` (radius r_b)."""
    half = 0.5 * float(np.linalg.norm(b - a))
    rot = _frame_along(b - a, up)
    return Part("cone", _affine(rot, (1.0, 1.0, max(half, 1e-4)), (a + b) / 2), colour, r_a, r_b)


def _ball(
    at: np.ndarray,
    r: float,
    colour: RGB,
    rot: np.ndarray | None = None,
    scale: tuple[float, float, float] | None = None,
    glow: bool = False,
) -> Part:
    """A ball of radius `r`, or an ellipsoid with semi-axes `scale` along the columns of `rot`."""
    rot = np.eye(3) if rot is None else rot
    return Part("sphere", _affine(rot, scale or (r, r, r), at), colour, glow=glow)


def _basis(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Rotation with columns x, y, z from a forward `x` and a left `y` (orthonormalised)."""
    y = y / np.linalg.norm(y)
    z = np.cross(x, y)
    z /= np.linalg.norm(z)
    return np.stack([np.cross(y, z), y, z], axis=1)


def static_parts() -> list[Part]:
    """The leg, the skirt of the base with its bumper, and the three omni wheels."""
    eye = np.eye(3)
    parts = [
        Part("cone", _affine(eye, (1, 1, 0.27), np.array([-0.02, 0, -0.30])), WHITE, 0.135, 0.085),
        Part("cone", _affine(eye, (1.05, 1, 0.08), np.array([-0.02, 0, -0.66])), WHITE, 0.26, 0.14),
        Part(
            "cone", _affine(eye, (1.05, 1, 0.025), np.array([-0.02, 0, -0.765])), DARK, 0.26, 0.26
        ),
        _ball(np.array([-0.02, 0.0, -0.03]), 0.075, GREY),  # the hip joint
    ]
    for angle in np.deg2rad([60.0, 180.0, 300.0]):
        axis = np.array([np.cos(angle), np.sin(angle), 0.0])
        centre = np.array([-0.02, 0, GROUND_Z + 0.035]) + 0.17 * axis
        rot = _frame_along(axis, np.array([0.0, 0.0, 1.0]))
        parts.append(Part("cone", _affine(rot, (0.035, 0.035, 0.02), centre), BLACK))
    return parts


def moving_parts(points: dict[str, np.ndarray]) -> list[Part]:
    """Torso with the tablet, head with eyes, arms with hands for one pose: `points` maps each
    `pepper.fk` point name to its `(3,)` position."""
    p = points
    up = np.array([0.0, 0.0, 1.0])
    torso = _basis(np.array([1.0, 0, 0]), p["left_shoulder"] - p["right_shoulder"])
    at = lambda v: torso @ np.asarray(v, float)  # noqa: E731 — a point of the torso link
    parts = [
        _ball(at([-0.035, 0, 0.125]), 0, WHITE, torso, (0.115, 0.16, 0.18)),  # chest
        _segment(at([-0.035, 0, -0.02]), at([-0.035, 0, 0.06]), 0.085, 0.11, WHITE, torso[:, 0]),
        _segment(at([-0.038, 0, 0.26]), p["head"], 0.04, 0.035, GREY, torso[:, 0]),  # neck
        # the tablet on the chest: black frame, a dark lit screen in front of it
        Part("box", _affine(torso, (0.012, 0.115, 0.08), at([0.075, 0, 0.115])), BLACK),
        Part("box", _affine(torso, (0.004, 0.1, 0.065), at([0.087, 0, 0.115])), SCREEN, glow=True),
    ]
    # the head: a slightly tall ball on the HeadPitch joint, oriented by the face markers
    ears = (p["left_ear"] + p["right_ear"]) / 2
    eyes = (p["left_eye"] + p["right_eye"]) / 2
    head = _basis(eyes - ears, p["left_ear"] - p["right_ear"])
    hat = lambda v: p["head"] + head @ np.asarray(v, float)  # noqa: E731 — on the head link
    parts.append(_ball(hat([0.0, 0, 0.105]), 0, WHITE, head, (0.1, 0.095, 0.105)))
    for side in (1.0, -1.0):
        parts.append(_ball(hat([0.078, side * 0.038, 0.115]), 0, BLACK, head, (0.02, 0.021, 0.021)))
        led = hat([0.094, side * 0.038, 0.115])
        parts.append(_ball(led, 0, EYE_LED, head, (0.006, 0.011, 0.011), glow=True))
        parts.append(
            _ball(hat([0.0, side * 0.09, 0.11]), 0, GREY, head, (0.03, 0.012, 0.03))
        )  # ear
    for s in ("left", "right"):
        sh, el, wr = p[f"{s}_shoulder"], p[f"{s}_elbow"], p[f"{s}_wrist"]
        fore = (wr - el) / max(float(np.linalg.norm(wr - el)), 1e-9)
        parts += [
            _ball(sh, 0.05, WHITE),
            _segment(sh, el, 0.045, 0.038, WHITE, up),
            _ball(el, 0.037, GREY),
            _segment(el, wr, 0.036, 0.03, WHITE, up),
            # the hand: a flat mitten beyond the wrist, its palm facing the body's midline
            _ball(wr + 0.05 * fore, 0, GREY, _frame_along(fore, torso[:, 1]), (0.022, 0.036, 0.06)),
        ]
    return parts
