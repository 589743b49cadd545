"""The 3D render of Pepper: the robot is drawn where its kinematics put it."""

from __future__ import annotations

from pathlib import Path

import av
import numpy as np
import pytest

from gesturebank.config import RenderConfig
from gesturebank.robot import body, pepper
from gesturebank.robot.render import camera
from gesturebank.robot.render3d import Scene

CONFIG = RenderConfig()  # the default camera: the look participants see


def pose(**joints: float) -> np.ndarray:
    p = pepper.neutral_pose().copy()
    for name, value in joints.items():
        p[pepper.INDEX[name]] = value
    return pepper.clamp(p.reshape(1, -1))[0]


# Arms stretched forward, head turned to the robot's left; and its opposite number.
FORWARD_LEFT = pose(LShoulderPitch=0.0, RShoulderPitch=0.0, HeadYaw=0.8)
DOWN_RIGHT = pose(HeadYaw=-0.8, HeadPitch=0.2)


@pytest.fixture(scope="module")
def scene() -> Scene:
    return Scene(camera(CONFIG))


def silhouette(scene: Scene, image: np.ndarray) -> np.ndarray:
    """Pixels that are not floor or sky: `(H, W)` bool."""
    return np.abs(image.astype(int) - scene.backdrop.astype(int)).max(axis=2) > 12


def pixels(scene: Scene, angles: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
    pts = pepper.fk(angles.reshape(1, -1))
    return np.rint(scene.camera.project(np.stack([pts[n][0] for n in names]))).astype(int)


def covered(mask: np.ndarray, px: np.ndarray) -> np.ndarray:
    """Whether each pixel `(N, 2)` (x, y) lies on the mask (within 1 px)."""
    h, w = mask.shape
    out = []
    for x, y in px:
        assert 0 <= x < w and 0 <= y < h, (x, y)
        out.append(mask[max(y - 1, 0) : y + 2, max(x - 1, 0) : x + 2].any())
    return np.array(out)


def led_centre(image: np.ndarray) -> np.ndarray:
    """Mean (x, y) of the pixels in the eyes' LED colour."""
    led = np.array(body.EYE_LED) * 255
    near = np.abs(image.astype(float) - led).max(axis=2) < 20
    ys, xs = np.nonzero(near)
    assert len(xs) > 3, "no eye LED visible"
    return np.array([xs.mean(), ys.mean()])


ARM = ("left_elbow", "left_wrist", "right_elbow", "right_wrist")


def test_frame_shows_arms_and_head_where_fk_puts_them(scene: Scene, artifacts: Path) -> None:
    img = scene.render(FORWARD_LEFT)
    assert img.shape == (CONFIG.height_px, CONFIG.width_px, 3)
    mask = silhouette(scene, img)
    names = (*ARM, "head", "nose", "left_eye", "right_eye")
    assert covered(mask, pixels(scene, FORWARD_LEFT, names)).all()
    av.VideoFrame.from_ndarray(img, format="rgb24").to_image().save(artifacts / "render3d.png")
    # the eyes' LEDs sit by the FK eye markers (drawn a few mm in front of them)
    eyes = pixels(scene, FORWARD_LEFT, ("left_eye", "right_eye")).mean(axis=0)
    assert np.linalg.norm(led_centre(img) - eyes) < 6


def test_another_pose_moves_arms_and_head(scene: Scene) -> None:
    a, b = scene.render(FORWARD_LEFT), scene.render(DOWN_RIGHT)
    mask_b = silhouette(scene, b)
    assert covered(mask_b, pixels(scene, DOWN_RIGHT, (*ARM, "head"))).all()
    # where the stretched-out wrists were, the picture changed; the arms hang elsewhere now
    wrists_a = pixels(scene, FORWARD_LEFT, ("left_wrist", "right_wrist"))
    wrists_b = pixels(scene, DOWN_RIGHT, ("left_wrist", "right_wrist"))
    assert np.linalg.norm(wrists_a - wrists_b, axis=1).min() > 20
    for x, y in wrists_a:
        assert np.abs(a[y, x].astype(int) - b[y, x].astype(int)).max() > 12
    # the face turned: the LEDs follow the projected eye markers of each pose
    shift = led_centre(b) - led_centre(a)
    expected = pixels(scene, DOWN_RIGHT, ("left_eye", "right_eye")).mean(axis=0) - pixels(
        scene, FORWARD_LEFT, ("left_eye", "right_eye")
    ).mean(axis=0)
    assert np.linalg.norm(expected) > 5
    assert np.linalg.norm(shift - expected) < 0.3 * np.linalg.norm(expected) + 3
