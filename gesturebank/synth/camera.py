"""Pinhole cameras placed around a figure: azimuth, elevation, distance, field of view.

The scene's frame comes from the motion itself: `up` is the world axis closest to the figure's
mean torso direction (BVH files are y-up or z-up), `forward` the figure's mean facing direction
made horizontal (over the rendered stretch: a BVH's rest pose need not stand upright, test.bvh's
does not), and the target the figure's mean chest (three quarters of the way from the mid-hip to
the mid-shoulder). A camera at azimuth 0 and elevation 0 stands `distance` in front of the
target at chest height and looks at it; positive azimuths turn it towards the person's left.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gesturebank.camera_files import Camera
from gesturebank.mocap.pose import body_axes
from gesturebank.skeletons import COCO17

CHEST = 0.75  # the chest, from the mid-hip (0) to the mid-shoulder (1)


@dataclass(frozen=True)
class Stage:
    """Where the figure stands: target (3,) metres, unit forward (3,) and up (3,) vectors."""

    target: np.ndarray
    forward: np.ndarray
    up: np.ndarray

    @property
    def left(self) -> np.ndarray:
        return np.cross(self.up, self.forward)


def stage_of(joints: np.ndarray) -> Stage:
    """The stage of COCO-17 `joints (T, 17, 3)` metres (module docstring)."""
    forward, _, torso_up = body_axes(joints)
    axis = int(np.argmax(np.abs(torso_up)))
    up = np.zeros(3)
    up[axis] = np.sign(torso_up[axis])
    forward = forward - forward @ up * up
    forward /= np.linalg.norm(forward)
    j = np.asarray(joints, np.float64)
    i = COCO17.index
    shoulders = (j[:, i["left_shoulder"]] + j[:, i["right_shoulder"]]) / 2
    hips = (j[:, i["left_hip"]] + j[:, i["right_hip"]]) / 2
    target = np.nanmean(CHEST * shoulders + (1 - CHEST) * hips, axis=0)
    return Stage(target=target, forward=forward, up=up)


def orbit_camera(
    stage: Stage,
    *,
    name: str,
    azimuth_deg: float,
    elevation_deg: float,
    distance_m: float,
    fov_deg: float,
    size: tuple[int, int],
) -> Camera:
    """A distortion-free pinhole camera looking at `stage.target` from the given direction;
    `fov_deg` is the vertical field of view, square pixels, principal point at the centre."""
    az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
    horizontal = np.cos(az) * stage.forward + np.sin(az) * stage.left
    eye = stage.target + distance_m * (np.cos(el) * horizontal + np.sin(el) * stage.up)
    z = stage.target - eye  # optical axis
    z /= np.linalg.norm(z)
    x = np.cross(z, stage.up)  # image right (right × down = optical axis)
    if np.linalg.norm(x) < 1e-9:  # looking straight down or up: any image right will do
        x = np.cross(z, stage.forward)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    rotation = np.stack([x, y, z])  # world → camera
    w, h = size
    focal = h / 2 / np.tan(np.radians(fov_deg) / 2)
    K = np.array([[focal, 0.0, (w - 1) / 2], [0.0, focal, (h - 1) / 2], [0.0, 0.0, 1.0]])
    return Camera(name, (w, h), K, np.zeros(0), rotation, -rotation @ eye)


def rays_through(camera: Camera, pixels: np.ndarray) -> np.ndarray:
    """(..., 6) float32 rays (origin, unit direction) in world coordinates through the pixel
    positions (..., 2) of a distortion-free `camera` (the inverse of `Camera.project`)."""
    px = np.asarray(pixels, np.float64)
    homogeneous = np.concatenate([px, np.ones_like(px[..., :1])], axis=-1)
    directions = homogeneous @ np.linalg.inv(camera.K).T @ camera.R  # camera → world: Rᵀ d
    directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
    origins = np.broadcast_to(camera.center, directions.shape)
    return np.concatenate([origins, directions], axis=-1).astype(np.float32)


def pixel_rays(camera: Camera, *, supersample: int) -> np.ndarray:
    """(H·s, W·s, 6) rays through the (sub)pixel centres, s = `supersample` per pixel along
    each axis; pixel (col i, row j) has its centre at (i, j), where OpenCV projects."""
    w, h = camera.size
    s = supersample
    offsets = (np.arange(s) + 0.5) / s - 0.5
    u = (np.arange(w)[:, None] + offsets[None, :]).ravel()
    v = (np.arange(h)[:, None] + offsets[None, :]).ravel()
    uu, vv = np.meshgrid(u, v)
    return rays_through(camera, np.stack([uu, vv], axis=-1))
