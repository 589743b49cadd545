"""The real Pose2Sim 4-camera demo as a multi-camera take — all four cameras, and every pair of
them beside the 4-camera calibration (a user drops the broken cameras) — through build-dataset
with the default config: accepted clips, no 3D jump or bone-length spread past the QC limits.

Each camera is ping-ponged to 5 s alike (so the cameras stay in sync) with the demo's own
Qualisys calibration and real speech as a .wav beside the videos.
"""

from __future__ import annotations

from itertools import combinations
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from scipy.io import wavfile

from gesturebank import footage
from gesturebank.config import Config
from gesturebank.datasets.build import build_dataset
from gesturebank.datasets.takes import discover_takes

DEMO = "pose2sim/Demo_SinglePerson"
CAMERAS = ("cam01", "cam02", "cam03", "cam04")
SECONDS = 5.0
# Measured with the default config (the reasons the QC gives, and why). A multi-camera take is
# judged by its 3D as its cameras see it (qc.metrics: spikes of the triangulated joints, facing
# away = away from every camera of the take). The person's chest faces cam02 (the torso's forward
# axis 19° from it, median) and cam01 (39°); cam03 and cam04 see the back (139°, 145°). The right
# elbow is bent ~90°, right at Pepper's RElbowRoll limit of 89.5°, and the right ElbowYaw is
# past 119.5° in a third of the frames: the robot-limit share is the motion, not the
# triangulation.
BEYOND_REACH = "a joint clamped at a robot limit in more than 60 % of frames"
NOT_YET = {
    CAMERAS: f"{BEYOND_REACH}: 69 % (RElbowYaw 43 %, RElbowRoll 40 %, RShoulderPitch 14 %)",
    ("cam01", "cam03"): f"{BEYOND_REACH}: 70 % (LElbowYaw 69 %: the straight left arm)",
    ("cam01", "cam04"): f"{BEYOND_REACH}: 70 % (RElbowYaw 49 %, RElbowRoll 36 %)",
    # Accepted at the last stop's CI, which read detections cached by earlier code; detected
    # afresh (this stop's detector and the one before alike) the clip is rejected.
    ("cam01", "cam02"): f"{BEYOND_REACH}: 80-83 %, and facing away in 45 % of frames",
    ("cam02", "cam04"): "right forearm length CV 33 % (opposite views, 138° apart), and "
    f"{BEYOND_REACH}: 84 % (RElbowYaw 70 %)",
    # The 3D is clean (spike 0.06, bone CV 10 %, no swap) but no camera of the take sees the
    # front: the person faces away from both in 100 % of frames.
    ("cam03", "cam04"): "facing away from every camera in 100 % of frames: both see the back",
}
RIGS = [
    pytest.param(
        r,
        marks=pytest.mark.xfail(
            r in NOT_YET, reason=NOT_YET.get(r, ""), raises=AssertionError, strict=True
        ),
    )
    for r in [CAMERAS, *combinations(CAMERAS, 2)]
]


@pytest.fixture(scope="module")
def videos(samples: Path) -> dict[str, Path]:
    """Each camera ping-ponged to 5 s (the same bytes every run: the detection cache hits),
    made once beside the samples (~15 s a camera) and remade when its recipe or inputs change."""
    out = samples.parent / "footage" / "demo5s"
    made = {}
    for cam in CAMERAS:
        recipe = footage.Recipe((f"{DEMO}/videos/{cam}.mp4",), (SECONDS,))
        footage.make_take(recipe, samples=samples, out=out / f"{cam}.mp4")
        made[cam] = out / f"{cam}.mp4"
    return made


def rig(root: Path, cameras: tuple[str, ...], videos: dict[str, Path], samples: Path) -> Path:
    """A take folder: the chosen cameras' videos, the 4-camera calibration, a .wav beside."""
    take = root / "lab"
    (take / "videos").mkdir(parents=True)
    for cam in cameras:
        (take / "videos" / f"{cam}.mp4").symlink_to(videos[cam])
    (take / "calibration").mkdir()
    (take / "calibration" / "Calib.qca.txt").symlink_to(
        samples / DEMO / "calibration/Calib.qca.txt"
    )
    speech = footage.looped_speech([samples / p for p in footage.SPEECH], seconds=SECONDS)
    wavfile.write(take / "speech.wav", footage.SPEECH_RATE, speech.astype(np.float32))
    return root


@pytest.mark.parametrize("cameras", RIGS, ids=lambda r: "+".join(r))
def test_demo_rig_builds_into_accepted_clips(
    cameras: tuple[str, ...], videos: dict[str, Path], samples: Path, tmp_path: Path
) -> None:
    root = rig(tmp_path / "videos", cameras, videos, samples)
    config = Config()
    summary = build_dataset(discover_takes(root), root, tmp_path / "out", config, dashboard=False)
    assert not summary.failed, summary.failed[0].reason
    clips = [
        r
        for r in pq.read_table(tmp_path / "out/manifest.parquet").to_pylist()
        if r["kind"] == "clip"
    ]
    assert clips
    verdicts = {r["clip_id"]: r["qc_reasons"] for r in clips if r["qc_status"] != "accepted"}
    assert not verdicts, verdicts
    for r in clips:
        m = dict(r["metrics"])
        assert m["bone_cv_max"] <= config.qc.max_bone_cv
        assert m["spike_max"] <= config.qc.max_spike  # 2D and 3D keypoint jumps
        assert r["duration_s"] > 0.8 * SECONDS
