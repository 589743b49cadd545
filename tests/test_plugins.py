"""Plug-in settings have one shape (issue 42 item 4): a toy detector and a toy lifter, installed
as a third-party distribution would be (one module and its entry points), bring their own
`[detector.NAME]` / `[lifter.NAME]` sections, validated by them, and the lifter's traits are read
from it instead of its name. The settings of the release before still load, with a warning that
names the new key."""

from __future__ import annotations

import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from gesturebank.config import Config, load_config
from gesturebank.errors import ConfigError
from gesturebank.extract.detectors import DETECTORS
from gesturebank.lift import LIFTERS, LifterTraits, TakeViews
from gesturebank.lift.clip_confidence import expected_hand_error_cm, lifter_traits
from gesturebank.lift.depth_confidence import DepthCalibration
from gesturebank.mocap import MOCAP
from gesturebank.poses import Pose2D

TOY = '''
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from gesturebank.lift import LifterTraits
from gesturebank.lift.depth_confidence import DepthCalibration
from gesturebank.poses import Pose2D, Pose3D


class ToyDetectorSettings(BaseModel):
    model_config = ConfigDict(extra="forbid")
    corner: float = Field(0.25, ge=0, le=1)


class ToyDetector:
    """Puts one COCO-17 person at (corner, corner) of the image in every frame."""

    name = "toy"
    section_model = ToyDetectorSettings

    def __init__(self, settings=None, *, video=None):
        self.settings = settings or ToyDetectorSettings()

    def detect(self, frames):
        times, size = [], (64, 48)
        for t, image in frames:
            times.append(t)
            size = (image.shape[1], image.shape[0])
        kp = np.zeros((len(times), 17, 3))
        kp[..., 0] = self.settings.corner * size[0]
        kp[..., 1] = self.settings.corner * size[1]
        kp[..., 2] = 1.0
        return Pose2D(kp, np.array(times), "coco17", size)


class ToyLifterSettings(BaseModel):
    model_config = ConfigDict(extra="forbid")
    depth: float = Field(1.0, gt=0)


class ToyLifter:
    """Every joint at `depth` metres behind its 2D point."""

    name = "toy"
    section_model = ToyLifterSettings
    traits = LifterTraits(depth_calibration=DepthCalibration((0.0, 1.0), (0.0, 0.0), (9.0, 3.0)))

    def __init__(self, *, settings):
        self.settings = settings

    @classmethod
    def from_config(cls, config):
        return cls(settings=config.lifter.settings("toy"))

    def lift(self, views):
        pose = views.single(self.name)
        xy = pose.to_coco17().keypoints[..., :2]
        z = np.full(xy.shape[:-1] + (1,), self.settings.depth)
        joints = np.concatenate([xy, z], axis=-1).astype(np.float32)
        return Pose3D(joints, np.ones(joints.shape[:2], np.float32), pose.timestamps, "camera")
'''


@pytest.fixture
def toy(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[str]:
    """A distribution "toy-plugins" declaring a detector and a lifter named "toy"."""
    (tmp_path / "toy_plugins.py").write_text(textwrap.dedent(TOY))
    dist = tmp_path / "toy_plugins-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: toy-plugins\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text(
        "[gesturebank.detectors]\ntoy = toy_plugins:ToyDetector\n\n"
        "[gesturebank.lifters]\ntoy = toy_plugins:ToyLifter.from_config\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    yield "toy"
    DETECTORS._factories.pop("toy", None)  # forget the loaded plug-ins
    LIFTERS._factories.pop("toy", None)
    sys.modules.pop("toy_plugins", None)


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "my.toml"
    path.write_text(textwrap.dedent(text))
    return path


def test_a_toy_detectors_section_is_its_own_and_checked_by_it(toy: str, tmp_path: Path) -> None:
    config = load_config(
        write(tmp_path, '[detector]\nname = "toy"\n[detector.toy]\ncorner = 0.5\n')
    )
    settings = config.detector.settings()
    assert type(settings).__name__ == "ToyDetectorSettings"
    assert settings.corner == 0.5  # type: ignore[union-attr]
    frames = [(i / 25, np.zeros((48, 64, 3), np.uint8)) for i in range(3)]
    pose = DETECTORS.create("toy", settings).detect(iter(frames))
    np.testing.assert_allclose(pose.keypoints[0, 0, :2], [32.0, 24.0])
    # unwritten: the plug-in's defaults; a misspelt or wrong key: one line naming it
    assert Config().detector.settings("toy").corner == 0.25  # type: ignore[union-attr]
    with pytest.raises(ConfigError, match=r"my.toml:\d+: detector: toy.cornr: unknown key"):
        load_config(write(tmp_path, "[detector.toy]\ncornr = 0.5\n"))
    with pytest.raises(ConfigError, match=r"detector: toy.corner: Input should be less"):
        load_config(write(tmp_path, "[detector.toy]\ncorner = 2\n"))
    with pytest.raises(ConfigError, match=r"detector: tyo: unknown key \(did you mean"):
        load_config(write(tmp_path, "[detector.tyo]\ncorner = 0.5\n"))


def test_a_toy_lifter_brings_its_section_and_its_traits(toy: str, tmp_path: Path) -> None:
    config = load_config(write(tmp_path, '[lifter]\nname = "toy"\n[lifter.toy]\ndepth = 2.5\n'))
    lifter = LIFTERS.create("toy", config)
    pose = Pose2D(np.full((4, 17, 3), 0.5), np.arange(4.0), "coco17", (64, 48))
    assert np.all(lifter.lift(TakeViews.of(pose)).joints[..., 2] == 2.5)
    traits = lifter_traits("toy")
    assert not traits.several_views and not traits.measured_depth
    assert expected_hand_error_cm(confidence=np.array([0.5]), lifter="toy") == pytest.approx(6.0)
    with pytest.raises(ConfigError, match=r"lifter: toy.depth: Input should be greater"):
        load_config(write(tmp_path, "[lifter.toy]\ndepth = 0\n"))


def test_the_built_in_lifters_declare_their_traits() -> None:
    assert lifter_traits("multiview") == LifterTraits(several_views=True, measured_depth=True)
    assert lifter_traits(MOCAP).measured_depth  # the MOCAP name: 3D read, not lifted
    for name in ("blazepose-world", "learned", "resolved"):
        assert isinstance(lifter_traits(name).depth_calibration, DepthCalibration), name
    for name in ("geometric", "fitted", "not-installed"):
        assert lifter_traits(name) == LifterTraits(), name


def test_the_sections_of_the_release_before_still_load_with_a_warning(tmp_path: Path) -> None:
    old = write(
        tmp_path,
        """\
        [detector]
        max_people = 2
        min_detection_confidence = 0.3
        json_suffix = "_kp"
        [geometric]
        units = "m"
        [learned]
        mirror_average = false
        """,
    )
    with pytest.warns(DeprecationWarning) as caught:
        config = load_config(old)
    said = " ".join(str(w.message) for w in caught)
    for new in (
        "detector.blazepose.max_people",
        "detector.mediapipe.min_detection_confidence",
        "detector.openpose-json.json_suffix",
        "[lifter.geometric]",
        "[lifter.learned]",
    ):
        assert new in said, new
    assert config.detector.blazepose.max_people == 2
    assert config.detector.blazepose.min_detection_confidence == 0.3
    assert config.detector.mediapipe.min_detection_confidence == 0.3
    assert config.detector.openpose_json.json_suffix == "_kp"
    assert config.lifter.geometric.units == "m" and not config.lifter.learned.mirror_average
    rewritten = load_config(
        write(
            tmp_path,
            """\
            [detector.blazepose]
            max_people = 2
            min_detection_confidence = 0.3
            [detector.mediapipe]
            min_detection_confidence = 0.3
            [detector.openpose-json]
            json_suffix = "_kp"
            [lifter.geometric]
            units = "m"
            [lifter.learned]
            mirror_average = false
            """,
        )
    )
    assert rewritten == config and rewritten.digest() == config.digest()


def test_the_resolved_config_dumps_and_loads_back_unchanged() -> None:
    config = Config()
    config.detector.openpose_json.json_suffix = "_kp"
    dumped = config.to_json_dict()
    assert dumped["detector"]["openpose-json"] == {"json_suffix": "_kp"}
    assert Config.model_validate(dumped) == config
