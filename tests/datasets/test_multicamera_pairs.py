"""The real Pose2Sim 4-camera demo as a multi-camera take — all four cameras, and every pair of
them beside the 4-camera calibration (a user drops the broken cameras) — through build-dataset
with the default config: every rig builds; its clips are accepted, with no 3D jump or
bone-length spread past the QC limits, or rejected only for the reasons ALLOWED names for it
(an expected failure, reported with the measured numbers).

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
from gesturebank.app.build import build_dataset
from gesturebank.config import Config
from gesturebank.datasets.takes import discover_takes

DEMO = "pose2sim/Demo_SinglePerson"
CAMERAS = ("cam01", "cam02", "cam03", "cam04")
SECONDS = 5.0
# A multi-camera take is judged by its 3D as its cameras see it (qc.metrics: spikes of the
# triangulated joints, facing away = away from every camera of the take). The person's chest
# faces cam02 (the torso's forward axis 19° from it, median) and cam01 (39°); cam03 and cam04 see
# the back (139°, 145°). The motion (a man flailing his arms on a treadmill) is beyond Pepper's
# reach in about half the frames: the right elbow bent past RElbowRoll's 89.5° (by 10° median in
# 41 % of frames, all four cameras), the right forearm turned past RElbowYaw's 119.5° (46 %), an
# arm raised behind the head past ShoulderPitch's −119.5° (14-16 %). That is reported
# (out_of_reach/<Joint>), not judged: with the clamp the robot stood at a limit in 68-71 % of the
# frames on cam01+cam03, cam01+cam04 and all four (rejected for it before), with the soft reach
# map 18 % (all four, benchmarks/retarget.py). Each rig may be rejected only for the reasons it
# names here, never for reach, a 3D jump, a swap or (but cam02+cam04) a bone-length spread.
BONES = "3D bone length varies"
AWAY = "facing away"
ALLOWED: dict[tuple[str, ...], tuple[str, ...]] = {
    CAMERAS: (),
    ("cam01", "cam02"): (),
    ("cam01", "cam03"): (),
    ("cam01", "cam04"): (),
    ("cam02", "cam03"): (),
    # opposite views, 138° apart: the right forearm's length varies by 32 %
    ("cam02", "cam04"): (BONES,),
    # the 3D is clean (spike 0.06, bone CV 10 %, no swap) but both cameras see the back
    ("cam03", "cam04"): (AWAY,),
}
RIGS = [CAMERAS, *combinations(CAMERAS, 2)]


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
    """Accepted clips, or clips rejected only for the rig's documented reasons (then xfail)."""
    root = rig(tmp_path / "videos", cameras, videos, samples)
    config = Config()
    summary = build_dataset(
        discover_takes(root), videos_dir=root, out=tmp_path / "out", config=config
    )
    assert not summary.failed, summary.failed[0].reason
    clips = [
        r
        for r in pq.read_table(tmp_path / "out/manifest.parquet").to_pylist()
        if r["kind"] == "clip"
    ]
    assert clips
    for r in clips:
        assert r["duration_s"] > 0.8 * SECONDS
        unexpected = [x for x in r["qc_reasons"] if not x.startswith(ALLOWED[cameras])]
        assert not unexpected, unexpected
        if r["qc_status"] == "accepted":
            m = dict(r["metrics"])
            assert m["bone_cv_max"] <= config.qc.max_bone_cv
            assert m["spike_max"] <= config.qc.max_spike  # 2D and 3D keypoint jumps
    rejected = [x for r in clips for x in r["qc_reasons"]]
    if rejected:
        pytest.xfail("; ".join(rejected))
