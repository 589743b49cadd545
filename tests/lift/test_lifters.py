"""The lifter protocol: every registered lifter is made from the Config by the registry and lifts a
`TakeViews`; monocular lifters take one view, the multi-view one two or more with cameras."""

from __future__ import annotations

import numpy as np
import pytest

from gesturebank.camera_files import Camera, CameraGroup
from gesturebank.config import Config
from gesturebank.errors import CalibrationError, InputError
from gesturebank.lift import LIFTERS, TakeViews
from gesturebank.poses import Pose2D

BUILT_IN = ["blazepose-world", "fitted", "geometric", "multiview"]
MONOCULAR = ["blazepose-world", "fitted", "geometric"]


def still(n: int = 3) -> Pose2D:
    """A COCO-17 pose with every keypoint at one place (the refusals come before any maths)."""
    return Pose2D(np.full((n, 17, 3), 0.5), np.arange(float(n)), "coco17", (64, 48))


def test_the_registry_makes_every_lifter_from_the_config_with_its_own_sections() -> None:
    config = Config.model_validate(
        {
            "lifter": {
                "geometric": {"units": "m"},
                "fitted": {"fov_deg": 40.0},
                "multiview": {"min_cameras": 3},
            }
        }
    )
    lifters = {name: LIFTERS.create(name, config) for name in BUILT_IN}
    assert [lifter.name for lifter in lifters.values()] == BUILT_IN
    assert lifters["geometric"].options == config.lifter.geometric  # type: ignore[attr-defined]
    assert lifters["fitted"].options == config.lifter.fitted  # type: ignore[attr-defined]
    assert lifters["fitted"].geometric == config.lifter.geometric  # type: ignore[attr-defined]
    assert lifters["multiview"].options == config.lifter.multiview  # type: ignore[attr-defined]


@pytest.mark.parametrize("name", MONOCULAR)
def test_a_monocular_lifter_refuses_several_views(name: str) -> None:
    with pytest.raises(InputError, match=rf"lifter '{name}' lifts one view, got 2"):
        LIFTERS.create(name, Config()).lift(TakeViews.of([still(), still()]))


def cameras(*names: str) -> CameraGroup:
    K = np.array([[50.0, 0, 32], [0, 50.0, 24], [0, 0, 1]])
    return CameraGroup([Camera(n, (64, 48), K, np.zeros(5), np.eye(3), np.zeros(3)) for n in names])


def test_the_multiview_lifter_needs_cameras_and_two_views() -> None:
    lifter = LIFTERS.create("multiview", Config())
    with pytest.raises(CalibrationError, match="no cameras"):
        lifter.lift(TakeViews.of([still(), still()]))
    with pytest.raises(InputError, match="needs two or more views, got 1"):
        lifter.lift(TakeViews.of(still(), cameras("a")))


def test_the_fitted_lifter_takes_the_one_camera_of_its_view() -> None:
    with pytest.raises(InputError, match=r"one view but 2 cameras \(\['a', 'b'\]\)"):
        LIFTERS.create("fitted", Config()).lift(TakeViews.of(still(), cameras("a", "b")))


def test_take_views_checks_what_it_holds() -> None:
    assert TakeViews.of(still()).poses[0].skeleton == "coco17"
    with pytest.raises(InputError, match="no view"):
        TakeViews(())
    with pytest.raises(InputError, match="1 audio tracks for 2 views"):
        TakeViews((still(), still()), audios=(None,))
