"""The renderer's own geometry: the truth's joints, projected by the written cameras, land on
the drawn figure where that joint is; the pixel grid casts the rays the cameras project."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gesturebank.synth.camera import orbit_camera, pixel_rays, rays_through, stage_of
from gesturebank.synth.figure import PART_INDEX
from gesturebank.synth.looks import LOOKS
from gesturebank.synth.raycast import MISS, Figure, cast

pytestmark = pytest.mark.media

HEAD = ("head", "nose", "hair", "left_ear", "right_ear")


def _parts(joint: str) -> tuple[tuple[str, ...], float]:
    """The parts a ray through `joint` may hit first, and how far (m) from the joint."""
    if joint in ("nose", "left_eye", "right_eye", "left_ear", "right_ear"):
        return HEAD, 0.13
    side, _, kind = joint.partition("_")
    return {
        "shoulder": ((f"{side}_upper_arm", "torso", "neck"), 0.1),
        "elbow": ((f"{side}_upper_arm", f"{side}_forearm"), 0.07),
        "wrist": ((f"{side}_forearm", f"{side}_hand"), 0.07),
        "hip": ((f"{side}_thigh", "pelvis", "torso"), 0.15),
        "knee": ((f"{side}_thigh", f"{side}_shin"), 0.08),
        "ankle": ((f"{side}_shin", f"{side}_foot"), 0.08),
    }[kind]


@settings(
    max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    azimuth=st.floats(-75, 75),
    elevation=st.floats(-20, 45),
    distance=st.floats(2.0, 6.0),
)
def test_projected_truth_lands_on_its_part(
    stretch_joints: np.ndarray, azimuth: float, elevation: float, distance: float
) -> None:
    from gesturebank.skeletons import COCO17

    figure = Figure(stretch_joints, np.zeros(len(stretch_joints)), LOOKS["tshirt"])
    camera = orbit_camera(
        stage_of(stretch_joints),
        name="cam01",
        azimuth_deg=azimuth,
        elevation_deg=elevation,
        distance_m=distance,
        fov_deg=50,
        size=(640, 480),
    )
    seen = 0
    for frame, joints in enumerate(stretch_joints):
        pixels = camera.project(joints)
        rays = rays_through(camera, pixels)[None]  # (1, 17, 6)
        hits = cast([figure], frame, rays=rays, box=(0, 0, 17, 1))
        depth = np.linalg.norm(joints - camera.center, axis=-1)
        hit_at = iter(range(int((hits.part != MISS).sum())))
        for j, name in enumerate(COCO17.joints):
            part = hits.part[0, j]
            assert part != MISS, f"frame {frame}: the ray through {name} misses the figure"
            point = hits.points[next(hit_at)]
            allowed, reach = _parts(name)
            on_it = part in [PART_INDEX[p] for p in allowed]
            if on_it and np.linalg.norm(point - joints[j]) <= reach:
                seen += 1
            else:  # something else is in front of it
                assert hits.depth[0, j] < depth[j] - reach / 2, (
                    f"frame {frame}: {name} lands on part {part} at "
                    f"{hits.depth[0, j]:.2f} m, the joint is at {depth[j]:.2f} m"
                )
    assert seen >= 0.6 * stretch_joints.shape[0] * stretch_joints.shape[1]


def test_pixel_grid_rays_pass_through_what_the_camera_projects(
    stretch_joints: np.ndarray,
) -> None:
    camera = orbit_camera(
        stage_of(stretch_joints),
        name="cam01",
        azimuth_deg=30,
        elevation_deg=10,
        distance_m=3,
        fov_deg=50,
        size=(64, 48),
    )
    rays = pixel_rays(camera, supersample=1)
    # a point 2.5 m along the ray of pixel (col 40, row 7) projects back onto that pixel
    point = rays[7, 40, :3] + 2.5 * rays[7, 40, 3:]
    np.testing.assert_allclose(camera.project(point), [40, 7], atol=1e-3)
    fine = pixel_rays(camera, supersample=2)
    # sub-pixel rays straddle the pixel centre: their mean is its ray
    np.testing.assert_allclose(fine[14:16, 80:82, 3:].mean(axis=(0, 1)), rays[7, 40, 3:], atol=1e-3)
