"""build-dataset on the real sample clips: clips on disk, resuming after SIGKILL, Ray."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from gesturebank.app.build import build_dataset, content_digest, with_threads
from gesturebank.app.clip import audio_clock
from gesturebank.config import Config
from gesturebank.datasets.takes import discover_takes
from gesturebank.errors import InputError

BIN = Path(sys.executable).parent
TIMING = {"detect_s"}  # metrics that measure the run, not the data


def test_layout_read_with_pyarrow_and_numpy_only(demo_dataset: Path) -> None:
    """What a user's script sees, without any gesturebank code."""
    info = json.loads((demo_dataset / "dataset.json").read_text())
    assert info["schema_version"] == 5
    assert info["rates"] == {"pose_hz": 100.0, "audio_hz": 100.0}
    # models trained on the features must know their window (the dissertation's: none)
    assert info["audio_features"]["params"]["window"] == "none"
    assert len(info["joints"]) == 11
    lower = np.array([info["limits"][j]["lower"] for j in info["joints"]])
    upper = np.array([info["limits"][j]["upper"] for j in info["joints"]])
    manifest = pq.read_table(demo_dataset / "manifest.parquet").to_pylist()
    assert {r["take_id"] for r in manifest} == {
        "lab__cam01_arctic",
        "lab__cam03_arctic",
        "outdoor__sports2d_arctic",
    }
    clips = [r for r in manifest if r["kind"] == "clip"]
    assert clips, "the demo gives clips"
    for take, summary in info["takes"].items():
        rows = [r for r in manifest if r["take_id"] == take]
        # the clips and dropped spans cover the take (up to a 100 Hz frame at each seam)
        covered = sum(r["end_s"] - r["start_s"] for r in rows)
        assert covered == pytest.approx(summary["seconds"], abs=0.02 * len(rows) + 0.05)
        usable = sum(r["duration_s"] for r in rows if r["qc_status"] == "accepted")
        assert summary["usable_s"] == pytest.approx(usable)
    for row in clips:
        assert row["qc_status"] in ("accepted", "rejected")
        path = demo_dataset / "takes" / row["take_id"] / f"{row['clip_id']}.npz"
        with np.load(path, allow_pickle=False) as d:
            angles, angles01, audio, times = d["angles"], d["angles01"], d["audio"], d["times"]
            mask, raw, ts = d["mask"], d["raw_angles"], d["timestamps"]
            roll = d["head_roll"]
            assert d["pose3d_joints"].shape == (len(ts), 17, 3)
            confidence = d["depth_confidence"]
            assert confidence.shape == ts.shape and confidence.dtype == np.float32
            assert ((confidence >= 0) & (confidence <= 1)).all()
            # the manifest's columns are the clip's mean and its lifter's calibration
            assert row["depth_confidence"] == pytest.approx(float(confidence.mean()), abs=1e-6)
            assert np.isfinite(row["expected_hand_error_cm"])  # blazepose-world: calibrated
            start = float(d["start_s"])
        n = row["n_frames"]
        assert angles.shape == angles01.shape == mask.shape == (n, 11)
        assert audio.shape == (n, info["audio_features"]["dim"])
        assert angles.dtype == audio.dtype == np.float32
        assert times[0] == 0.0 and start == pytest.approx(row["start_s"])
        np.testing.assert_allclose(np.diff(times), 0.01, atol=1e-9)  # 100 Hz
        assert raw.shape == (len(ts), 11)
        assert row["duration_s"] == pytest.approx(n / 100)
        assert row["duration_s"] >= 3.0  # clips.min_s
        np.testing.assert_array_equal(mask, np.isfinite(angles))
        assert row["parts"] == "head+arms"  # the demo's speakers are seen whole
        assert roll.shape == (n,) and np.isfinite(roll[mask[:, 0]]).mean() > 0.9
        ok = mask
        assert ok.mean() > 0.5
        assert np.all((angles >= lower) | ~ok) and np.all((angles <= upper) | ~ok)
        assert np.all((angles01[ok] >= 0) & (angles01[ok] <= 1))
        # the video frames cover the 100 Hz clock they were resampled onto
        assert ts[0] <= times[0] + 1e-9 and times[-1] <= ts[-1] + 1e-9
    assert (demo_dataset / "splits" / "sd.json").is_file()


def test_audio_clock_is_the_common_span() -> None:
    pose_t = np.arange(0.1, 2.0, 1 / 30)  # video 0.1 … 1.9 s
    i0, i1, t = audio_clock(pose_t, audio_start_s=0.0, n_frames=150, hop_s=0.01, win_s=0.025)
    assert t[0] >= pose_t[0] and t[0] - 0.01 < pose_t[0]  # first centre inside the video
    assert t[-1] <= 1.5 - 0.01 + 0.0125  # audio (150 frames) ends first
    assert i1 == 149
    np.testing.assert_allclose(t, 0.0125 + 0.01 * np.arange(i0, i1 + 1))
    with pytest.raises(InputError, match="do not overlap"):
        audio_clock(pose_t + 10, 0.0, n_frames=150, hop_s=0.01, win_s=0.025)


def test_every_config_section_is_content_or_not() -> None:
    """A new section must be classified: content (a change rebuilds the built takes) or not."""
    from gesturebank.datasets.digest import CONTENT_SECTIONS, NOT_CONTENT_SECTIONS

    sections = set(Config.model_fields)
    assert sections == set(CONTENT_SECTIONS) | set(NOT_CONTENT_SECTIONS)
    assert not set(CONTENT_SECTIONS) & set(NOT_CONTENT_SECTIONS)
    config = Config.model_validate({"lifter": {"fitted": {"fov_deg": 70.0}}})
    assert content_digest(config) != content_digest(Config())  # [fitted] changes a take


def test_threads_share_the_cores_between_workers() -> None:
    def threads(workers: int, cores: int, **build: object) -> tuple[int | None, int | None]:
        config = Config.model_validate({"build": build})
        resolved = with_threads(config, workers=workers, cores=cores)
        assert content_digest(resolved) == content_digest(config)  # how, not what
        return resolved.build.decode_threads, resolved.build.inference_threads

    assert threads(1, 2) == (2, 2)  # a lone worker uses the spare core
    assert threads(2, 2) == (1, 1) and threads(3, 2) == (1, 1)  # a full pool: no oversubscription
    assert threads(2, 8) == (4, 4)
    assert threads(1, 8, executor="ray") == (1, 1)  # a Ray task reserves one CPU
    assert threads(2, 2, decode_threads=3) == (3, 1)  # as set


def test_a_worker_keeps_opencvs_pool_within_its_budget() -> None:
    """Issue 43: OpenCV's pool (the crops and resizes around the models) is one of the worker's
    pools: within build.inference_threads while a take is built, as it was after."""
    import cv2

    from gesturebank.app.take_job import thread_budget

    before = cv2.getNumThreads()
    config = Config.model_validate({"build": {"inference_threads": 1}})
    with thread_budget(config):
        assert cv2.getNumThreads() == 1
    assert cv2.getNumThreads() == before


def test_a_build_confined_to_some_cores_divides_those() -> None:
    import os

    from gesturebank.app.build import usable_cores

    if not hasattr(os, "sched_getaffinity"):
        pytest.skip("no CPU affinity on this platform")
    assert usable_cores() == len(os.sched_getaffinity(0))


def dataset_contents(out: Path) -> dict:
    rows = pq.read_table(out / "manifest.parquet").to_pylist()
    for r in rows:
        r["metrics"] = {k: v for k, v in r["metrics"] if k not in TIMING}
    arrays = {}
    for r in rows:
        if r["kind"] == "clip":
            path = out / "takes" / r["take_id"] / f"{r['clip_id']}.npz"
            with np.load(path, allow_pickle=False) as d:
                arrays[r["clip_id"]] = {k: d[k] for k in d.files}
    return {"rows": rows, "arrays": arrays}


def assert_same_dataset(a: Path, b: Path) -> None:
    ca, cb = dataset_contents(a), dataset_contents(b)
    assert ca["rows"] == cb["rows"]
    for clip, arrays in ca["arrays"].items():
        assert arrays.keys() == cb["arrays"][clip].keys()
        for key, value in arrays.items():
            np.testing.assert_array_equal(value, cb["arrays"][clip][key], err_msg=f"{clip} {key}")


def test_sigkill_mid_build_then_rerun_gives_the_same_dataset(
    samples: Path, demo_dataset: Path, tmp_path: Path
) -> None:
    videos, out = samples / "talking", tmp_path / "out"
    cmd = [str(BIN / "build-dataset"), str(videos), str(out), "--workers", "1", "--quiet"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while not list((out / "takes").glob("*.json")) and time.monotonic() < deadline:
        time.sleep(0.005)
    os.kill(proc.pid, signal.SIGKILL)  # while the next take is being processed
    proc.wait()
    done = {p.stem for p in (out / "takes").glob("*.json")}
    assert 1 <= len(done) < 3, "the kill should land mid-build"
    for npz in (out / "takes").glob("*/*.npz"):  # whatever is under a final name is complete
        with np.load(npz, allow_pickle=False) as d:
            assert d["angles"].shape[1] == 11
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    assert r.returncode == 0, r.stderr
    assert not list((out / "takes").glob(".*"))  # no temporary files left behind
    assert_same_dataset(out, demo_dataset)


def test_rerun_skips_built_takes_and_force_rebuilds(demo_dataset: Path, samples: Path) -> None:
    videos = samples / "talking"
    before = {p: p.stat().st_mtime_ns for p in (demo_dataset / "takes").glob("*/*.npz")}
    summary = build_dataset(
        discover_takes(videos), videos_dir=videos, out=demo_dataset, config=Config()
    )
    assert summary.count("skipped") == 3
    assert {p: p.stat().st_mtime_ns for p in (demo_dataset / "takes").glob("*/*.npz")} == before
    changed = Config.model_validate({"processing": {"cutoff_hz": 6.0}})
    summary = build_dataset(
        discover_takes(videos), videos_dir=videos, out=demo_dataset, config=changed
    )
    assert summary.count("built") == 3  # a changed config rebuilds
    summary = build_dataset(
        discover_takes(videos), videos_dir=videos, out=demo_dataset, config=Config(), force=True
    )
    assert summary.count("built") == 3


def test_bad_take_fails_alone(samples: Path, tmp_path: Path) -> None:
    videos = tmp_path / "videos"
    (videos / "s1").mkdir(parents=True)
    (videos / "s1" / "good.mp4").symlink_to(samples / "talking/lab/cam01_arctic.mp4")
    (videos / "s1" / "broken.mp4").write_bytes(b"\x00\x00\x00\x18ftypmp42 not a real video")
    (videos / "s1" / "silent.mp4").symlink_to(
        samples / "pose2sim/Demo_SinglePerson/videos/cam04.mp4"
    )
    out = tmp_path / "out"
    r = subprocess.run(
        [str(BIN / "build-dataset"), str(videos), str(out), "--workers", "2"],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert r.returncode == 1  # some takes failed
    rows = pq.read_table(out / "manifest.parquet").to_pylist()
    good = [row for row in rows if row["take_id"] == "s1__good" and row["kind"] == "clip"]
    assert good and good[0]["qc_status"] == "accepted"
    failed = {row["take_id"]: row for row in rows if row["qc_status"] == "failed"}
    assert set(failed) == {"s1__broken", "s1__silent"}
    assert "broken.mp4" in failed["s1__broken"]["qc_reasons"][0]
    assert "no audio" in failed["s1__silent"]["qc_reasons"][0]
    assert not list((out / "takes" / "s1__broken").glob("*.npz"))
    assert "failed s1__broken" in r.stdout.replace("\n", " ")


@pytest.mark.slow
def test_ray_executor_gives_the_same_dataset(samples: Path, demo_dataset: Path, tmp_path) -> None:
    pytest.importorskip("ray")
    videos = samples / "talking"
    config = Config.model_validate({"build": {"executor": "ray"}})
    summary = build_dataset(discover_takes(videos), videos_dir=videos, out=tmp_path, config=config)
    assert summary.count("built") == 3
    assert_same_dataset(tmp_path, demo_dataset)


def test_ctrl_c_stops_cleanly_and_a_rerun_resumes(samples: Path, tmp_path: Path) -> None:
    videos, out = samples / "talking", tmp_path / "out"
    cmd = [str(BIN / "build-dataset"), str(videos), str(out), "--workers", "2", "--no-cache"]
    # own process group, so the SIGINT reaches the workers too, as Ctrl-C in a terminal does
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, start_new_session=True
    )
    deadline = time.monotonic() + 120
    while not list((out / "takes").glob("*.json")) and time.monotonic() < deadline:
        time.sleep(0.005)
    os.killpg(proc.pid, signal.SIGINT)
    stdout, _ = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert "interrupted" in stdout
    assert not list((out / "takes").glob(".*"))  # no temporary or half-written files
    done = {p.stem for p in (out / "takes").glob("*.json")}
    manifest = pq.read_table(out / "manifest.parquet").to_pylist()
    assert {r["take_id"] for r in manifest if r["qc_status"] != "failed"} == done
    # the rerun may read the detection cache (the suite's other builds filled it): the cache
    # was off above only so that the interrupt lands mid-build
    r = subprocess.run(cmd[:-1], capture_output=True, text=True, timeout=300, check=False)
    assert r.returncode == 0, r.stdout
    takes = {r["take_id"] for r in pq.read_table(out / "manifest.parquet").to_pylist()}
    assert len(takes) == 3
