"""The multiview lifter on a render's own truth (issue 30): the true 2D of every camera and the
render's calibration.toml give back the motion, so Pepper's hand lands within a centimetre."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturebank.camera_files import load_cameras
from gesturebank.config import Config, SynthConfig
from gesturebank.lift import LIFTERS, TakeViews
from gesturebank.lift.scoring import project_view, score_lift
from gesturebank.poses import Pose3D
from gesturebank.synth.take import Performer, cached_render, rig_azimuths
from gesturebank.synth.truth import CALIBRATION
from tests.synth.conftest import START_S

pytestmark = pytest.mark.media


def test_true_2d_of_a_rendered_rig_lifts_to_the_truth(
    test_bvh: Path, speech: list[Path], tmp_path: Path
) -> None:
    config = Config()
    azimuths = rig_azimuths(centre_deg=0.0, count=3, spread_deg=90.0)
    synth = SynthConfig(
        azimuths_deg=azimuths, width_px=320, height_px=180, start_s=START_S, length_s=0.5
    )
    truth = cached_render(
        [Performer(test_bvh)], config=synth, mocap=config.mocap, speech=speech, cache=tmp_path
    )
    cameras = load_cameras(truth.folder / CALIBRATION)
    joints = truth.joints3d.astype(np.float64)
    views = [project_view(joints, camera, timestamps=truth.times) for camera in cameras]
    lifted = LIFTERS.create("multiview", config).lift(TakeViews.of(views, cameras))
    assert lifted.frame == "world" and len(lifted) == len(truth.times)
    np.testing.assert_allclose(lifted.joints, joints, atol=1e-3)  # metres
    in_camera = Pose3D(
        cameras[0].to_camera(lifted.joints.astype(np.float64)),
        lifted.confidence,
        lifted.timestamps,
    )
    score = score_lift(in_camera, joints, camera=cameras[0], retarget=config.retarget)
    assert score.hand_cm <= 1.0 and score.elbow_cm <= 1.0
    assert score.wrong_sign_pct == 0.0
