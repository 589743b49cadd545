"""Camera rigs for tests and benchmarks: a calibration put off by a known amount."""

from __future__ import annotations

import numpy as np

from gesturebank.camera_files import CameraGroup
from gesturebank.geometry import Camera, rodrigues_to_matrix


def _unit_vector(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def perturb_cameras(
    cameras: CameraGroup, *, rotation_deg: float, shift_m: float, seed: int, fixed: int = 0
) -> CameraGroup:
    """`cameras` with each one but `fixed` turned by exactly `rotation_deg` about a random axis
    (through its centre) and its centre moved by exactly `shift_m` in a random direction
    (seeded)."""
    rng = np.random.default_rng(seed)
    out = []
    for c, cam in enumerate(cameras):
        if c == fixed:
            out.append(cam)
            continue
        turn = rodrigues_to_matrix(np.radians(rotation_deg) * _unit_vector(rng))
        R = turn @ cam.R
        centre = cam.center + shift_m * _unit_vector(rng)
        out.append(Camera(cam.name, cam.size, cam.K, cam.dist, R, -R @ centre))
    return CameraGroup(out)
