"""A small software renderer: `body` parts ray-cast per pixel with a depth buffer and Lambert
shading, from a perspective camera orbiting the robot. NumPy only, headless, no GPU.

Each part's unit shape is intersected exactly in its own frame (sphere, capped cone, box), only
over the pixels of its projected bounding box; the nearest hit wins. The parts that never move
(leg, base, wheels) and the floor are drawn once per camera (`Scene`), each frame adds the
moving ones. Images are `(H, W, 3)` uint8 RGB.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np

from gesturebank.robot import body, pepper

_LIGHT = np.array([0.45, 0.55, 0.70])  # key light, from the front-left above (robot frame)
_AMBIENT, _DIFFUSE = 0.32, 0.72
_SKY, _FLOOR = np.array([0.80, 0.82, 0.85]), np.array([0.66, 0.66, 0.64])


@dataclass(frozen=True)
class Camera:
    """A pinhole camera looking at the robot from `azimuth_deg` (0: straight in front, positive:
    towards the robot's left), `elevation_deg` above the horizon, `distance_m` from the point
    half-way up the robot, with a vertical field of view `fov_deg`; image `width` × `height` px."""

    azimuth_deg: float
    elevation_deg: float
    distance_m: float
    fov_deg: float
    width: int
    height: int

    @cached_property
    def target(self) -> np.ndarray:
        return np.array([0.0, 0.0, (body.GROUND_Z + body.TOP_Z + 0.12) / 2])

    @cached_property
    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        """(eye (3,), rotation (3, 3) with columns right, down, forward) in the robot frame."""
        az, el = np.deg2rad(self.azimuth_deg), np.deg2rad(self.elevation_deg)
        eye = self.target + self.distance_m * np.array(
            [np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)]
        )
        fwd = self.target - eye
        fwd /= np.linalg.norm(fwd)
        right = np.cross(fwd, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        return eye, np.stack([right, np.cross(fwd, right), fwd], axis=1)

    @cached_property
    def focal_px(self) -> float:
        return 0.5 * self.height / np.tan(np.deg2rad(self.fov_deg) / 2)

    def project(self, points: np.ndarray) -> np.ndarray:
        """Robot-frame points `(..., 3)` → pixel coordinates `(..., 2)` float (x right, y down)."""
        eye, rot = self.pose
        cam = (np.asarray(points, float) - eye) @ rot
        z = np.maximum(cam[..., 2], 1e-6)
        return np.stack(
            [
                self.width / 2 + self.focal_px * cam[..., 0] / z,
                self.height / 2 + self.focal_px * cam[..., 1] / z,
            ],
            axis=-1,
        )

    @cached_property
    def rays(self) -> np.ndarray:
        """`(H, W, 3)` world directions through each pixel centre (unit depth along forward)."""
        _, rot = self.pose
        u = (np.arange(self.width) + 0.5 - self.width / 2) / self.focal_px
        v = (np.arange(self.height) + 0.5 - self.height / 2) / self.focal_px
        cam = np.stack(np.broadcast_arrays(u[None, :], v[:, None], 1.0), axis=-1)
        return (cam @ rot.T).astype(np.float32)  # float32: half the memory traffic per frame


_UNIT_CUBE = np.array([[x, y, z, 1.0] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])


def _hit(part: body.Part, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ray parameters t `(M,)` (inf: missed) and unit-frame normals `(M, 3)` of `part` for
    unit-frame origin `o (3,)` and directions `d (M, 3)`."""
    m = len(d)
    t = np.full(m, np.inf, d.dtype)
    n = np.zeros((m, 3), d.dtype)
    if part.kind == "sphere":
        b = d @ o
        a = np.einsum("ij,ij->i", d, d)
        disc = b * b - a * (o @ o - 1.0)
        ok = disc >= 0
        root = (-b[ok] - np.sqrt(disc[ok])) / a[ok]
        good = root > 0
        idx = np.flatnonzero(ok)[good]
        t[idx] = root[good]
        n[idx] = o + root[good, None] * d[idx]
    elif part.kind == "box":
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / d
            lo, hi = (-1.0 - o) * inv, (1.0 - o) * inv
        near = np.minimum(lo, hi)
        t_in, t_out = np.nanmax(near, axis=1), np.nanmin(np.maximum(lo, hi), axis=1)
        ok = (t_in <= t_out) & (t_in > 0)
        t[ok] = t_in[ok]
        axis = np.argmax(near[ok], axis=1)
        n[np.flatnonzero(ok), axis] = -np.sign(d[ok, axis])
    else:  # a capped cone along z: radius r(z) = k z + c for z in [−1, 1]
        k, c = (part.r1 - part.r0) / 2, (part.r1 + part.r0) / 2
        rz_o = k * o[2] + c
        a = d[:, 0] ** 2 + d[:, 1] ** 2 - (k * d[:, 2]) ** 2
        b = o[0] * d[:, 0] + o[1] * d[:, 1] - rz_o * k * d[:, 2]
        cc = o[0] ** 2 + o[1] ** 2 - rz_o**2
        disc = b * b - a * cc
        with np.errstate(divide="ignore", invalid="ignore"):
            for sign in (-1.0, 1.0):  # both roots: the near one may lie on the far nappe
                root = (-b + sign * np.sqrt(np.maximum(disc, 0))) / a
                z = o[2] + root * d[:, 2]
                ok = (disc >= 0) & (root > 0) & (np.abs(z) <= 1) & (k * z + c > 0) & (root < t)
                t[ok] = root[ok]
                p = o + root[ok, None] * d[ok]
                n[ok] = np.stack([p[:, 0], p[:, 1], -k * (k * p[:, 2] + c)], axis=1)
            for zc, r in ((-1.0, part.r0), (1.0, part.r1)):
                root = (zc - o[2]) / d[:, 2]
                p = o + root[:, None] * d
                ok = (root > 0) & (p[:, 0] ** 2 + p[:, 1] ** 2 <= r * r) & (root < t)
                t[ok] = root[ok]
                n[ok] = (0.0, 0.0, zc)
    return t, n


class Scene:
    """The floor and the static parts seen by `camera`, drawn once; `render` adds a pose.

    `backdrop` is the floor and sky alone `(H, W, 3)` uint8: what is not the robot."""

    def __init__(self, camera: Camera) -> None:
        self.camera = camera
        eye, _ = camera.pose
        rays = camera.rays
        # floor (z = GROUND_Z) fading into the sky at the horizon, and a soft shadow of the base
        with np.errstate(divide="ignore", invalid="ignore"):
            t_floor = (body.GROUND_Z - eye[2]) / rays[..., 2]
        on_floor = t_floor > 0
        hit = eye + np.where(on_floor, t_floor, 0)[..., None] * rays
        r = np.hypot(hit[..., 0] + 0.02, hit[..., 1])
        shade = 1.0 - 0.35 * np.exp(-((np.maximum(r - 0.12, 0) / 0.16) ** 2))
        fade = np.exp(-np.where(on_floor, t_floor, np.inf) / 12.0)[..., None]
        floor = _FLOOR * shade[..., None] * fade + _SKY * (1 - fade)
        self.colour = np.where(on_floor[..., None], floor, _SKY).astype(np.float32)
        self.backdrop = np.clip(self.colour * 255 + 0.5, 0, 255).astype(np.uint8)  # no robot
        self.depth = np.full(rays.shape[:2], np.inf, np.float32)
        self._draw(body.static_parts(), self.colour, self.depth)

    def render(self, angles: np.ndarray, model: Literal["urdf", "ideal"] = "urdf") -> np.ndarray:
        """One pose `(11,)` rad → `(H, W, 3)` uint8 RGB."""
        points = {
            k: v[0] for k, v in pepper.fk(np.asarray(angles).reshape(1, -1), model=model).items()
        }
        colour, depth = self.colour.copy(), self.depth.copy()
        self._draw(body.moving_parts(points), colour, depth)
        return np.clip(colour * 255 + 0.5, 0, 255).astype(np.uint8)

    def _draw(self, parts: list[body.Part], colour: np.ndarray, depth: np.ndarray) -> None:
        cam = self.camera
        eye, _ = cam.pose
        for part in parts:
            reach = max(part.r0, part.r1) if part.kind == "cone" else 1.0
            corners = (part.matrix @ (_UNIT_CUBE * [reach, reach, 1, 1]).T).T[:, :3]
            px = cam.project(corners)
            x0, y0 = np.maximum(np.floor(px.min(axis=0)).astype(int), 0)
            x1 = min(int(np.ceil(px[:, 0].max())) + 1, cam.width)
            y1 = min(int(np.ceil(px[:, 1].max())) + 1, cam.height)
            if x0 >= x1 or y0 >= y1:
                continue
            rays = cam.rays[y0:y1, x0:x1].reshape(-1, 3)
            inv = np.linalg.inv(part.matrix[:3, :3]).astype(np.float32)
            origin = (inv @ (eye - part.matrix[:3, 3])).astype(np.float32)
            t, n_unit = _hit(part, origin, rays @ inv.T)
            box = depth[y0:y1, x0:x1]  # views: written in place
            front = t.reshape(box.shape) < box
            win = np.flatnonzero(front)
            if not len(win):
                continue
            box[front] = t[win]
            rgb = np.asarray(part.colour, np.float32)
            if part.glow:
                shaded = np.broadcast_to(rgb, (len(win), 3))
            else:
                normal = n_unit[win] @ inv  # normals map by the inverse transpose
                normal /= np.linalg.norm(normal, axis=1, keepdims=True) + 1e-12
                facing = np.einsum("ij,ij->i", normal, -rays[win]) < 0
                normal[facing] *= -1  # seen from inside (a cone's cap from below): flip
                lam = np.clip(normal @ (_LIGHT / np.linalg.norm(_LIGHT)), 0, 1)
                rim = np.clip(normal @ np.array([0.0, 0.0, 1.0]), 0, 1) * 0.08
                shaded = rgb * (_AMBIENT + _DIFFUSE * lam + rim)[:, None]
            colour[y0:y1, x0:x1][front] = shaded
