"""Issue 31's acceptance on real media: continuous, speed-bounded angles and motion beyond the
robot's reach kept (the talking demo, the outdoor take, the bvhtools motion-capture take)."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from scipy.io import wavfile

from gesturebank import footage
from gesturebank.app.build import build_dataset
from gesturebank.config import Config
from gesturebank.datasets.takes import discover_takes
from gesturebank.mocap.bvh import read_bvh, write_bvh
from gesturebank.robot import pepper
from gesturebank.testing.mocap import BVH

PROFILE = pepper.load_profile()
BOUND = Config().qc.max_speed_factor * PROFILE.velocity / Config().processing.rate_hz


def _clips(out: Path) -> list[dict]:
    return [r for r in pq.read_table(out / "manifest.parquet").to_pylist() if r["kind"] == "clip"]


def test_the_demo_keeps_its_takes_with_no_step_faster_than_the_robot(demo_dataset: Path) -> None:
    """`make demo`: the lab take and the outdoor take (whose stored angles jumped across
    RShoulderPitch's whole range in one 10 ms frame) are kept, every stored step within
    qc.max_speed_factor × the joint speed."""
    clips = _clips(demo_dataset)
    kept = {r["take_id"]: r["duration_s"] for r in clips if r["qc_status"] == "accepted"}
    assert {"lab__cam01_arctic", "outdoor__sports2d_arctic"} <= set(kept), clips
    assert round(sum(kept.values()), 1) >= 12.7  # 7.06 s + 5.63 s: both takes whole, as before
    for r in clips:
        with np.load(demo_dataset / "takes" / r["take_id"] / f"{r['clip_id']}.npz") as d:
            steps = np.abs(np.diff(d["angles"].astype(np.float64), axis=0))
        assert np.nanmax(steps / BOUND) <= 1.0, (r["clip_id"], np.nanmax(steps / BOUND, axis=0))


@pytest.fixture(scope="module")
def mocap_30s(samples: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The first 30 s of test.bvh (its right elbow bent past RElbowRoll's limit in most
    frames) with real speech beside it, built."""
    root = tmp_path_factory.mktemp("mocap30")
    take = root / "videos" / "freemocap"
    take.mkdir(parents=True)
    motion = read_bvh(samples / BVH)
    write_bvh(take / "talk.bvh", motion.frames(0, 900))
    speech = footage.looped_speech([samples / p for p in footage.SPEECH], seconds=30.0)
    wavfile.write(take / "talk.wav", footage.SPEECH_RATE, speech.astype(np.float32))
    out = root / "out"
    summary = build_dataset(
        discover_takes(root / "videos"), videos_dir=root / "videos", out=out, config=Config()
    )
    assert not summary.failed, summary.failed
    shutil.rmtree(root / "videos")
    return out


def test_mocap_beyond_reach_is_kept_and_reported(mocap_30s: Path) -> None:
    """Rejected before for reach ("a joint clamped at a robot limit in 90% of frames"): now
    ≥ 24 s of its 30 s are accepted, the elbow's share beyond reach in the manifest."""
    clips = _clips(mocap_30s)
    accepted = sum(r["duration_s"] for r in clips if r["qc_status"] == "accepted")
    assert accepted >= 24.0, [(r["duration_s"], r["qc_reasons"]) for r in clips]
    beyond = max(dict(r["metrics"])["out_of_reach/RElbowRoll"] for r in clips)
    assert beyond > 0.5
