"""Detection cache: keys, content hash, npz without pickle, atomic writes, reuse in the pipeline."""

from __future__ import annotations

import hashlib
from fractions import Fraction
from pathlib import Path

import av
import numpy as np
import pytest
from platformdirs import user_cache_dir

from gesturebank.app.extract import extract_take
from gesturebank.config import Config, DetectorConfig
from gesturebank.extract import cache as cache_mod
from gesturebank.extract.cache import DetectionCache, cache_key, default_cache_dir, video_digest
from gesturebank.extract.detectors import DETECTORS
from gesturebank.extract.shots import Shots
from gesturebank.poses import MultiPose2D, Pose2D


def some_people() -> MultiPose2D:
    rng = np.random.default_rng(0)
    kp = rng.uniform(0, 100, (4, 2, 33, 3)).astype(np.float32)
    kp[..., 2] /= 100
    kp[1, 1] = np.nan
    world = rng.normal(size=kp.shape).astype(np.float32)
    return MultiPose2D(kp, np.array([0, 0.1, 0.25, 0.3]), "blazepose33", (100, 80), world)


def shots_of(multi: MultiPose2D) -> Shots:
    change = np.linspace(0.0, 30.0, len(multi), dtype=np.float32)
    return Shots(multi.timestamps, multi.timestamps[2:3], change)


def test_save_load_round_trip_without_pickle(tmp_path: Path) -> None:
    store = DetectionCache(tmp_path)
    multi = some_people()
    path = store.save("k1", multi, shots_of(multi))
    with np.load(path, allow_pickle=False) as data:  # plain arrays only
        assert set(data.files) == {
            *("keypoints", "timestamps", "skeleton", "image_size", "world"),
            *("shots_timestamps", "shots_cuts", "shots_change"),
        }
    loaded = store.load("k1")
    assert loaded is not None
    back, shots = loaded
    np.testing.assert_array_equal(shots.cuts, [0.25])
    np.testing.assert_array_equal(shots.change, shots_of(multi).change)
    np.testing.assert_array_equal(back.keypoints, multi.keypoints)  # NaN == NaN here
    np.testing.assert_array_equal(back.world, multi.world)
    np.testing.assert_array_equal(back.timestamps, multi.timestamps)
    assert back.skeleton == "blazepose33" and back.image_size == (100, 80)
    assert store.load("other") is None
    assert [p.name for p in tmp_path.iterdir()] == ["k1.npz"]  # no temporary files left


def test_failed_write_leaves_no_entry_and_keeps_the_old_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    store = DetectionCache(tmp_path)
    people = some_people()
    store.save("k", people, shots_of(people))
    before = (tmp_path / "k.npz").read_bytes()

    def crash(file, **arrays):
        file.write(b"half an archive")
        raise KeyboardInterrupt  # killed mid-write

    monkeypatch.setattr(cache_mod.np, "savez", crash)
    with pytest.raises(KeyboardInterrupt):
        store.save("k", people, shots_of(people))
    with pytest.raises(KeyboardInterrupt):
        store.save("new", people, shots_of(people))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["k.npz"]
    assert (tmp_path / "k.npz").read_bytes() == before


def test_corrupt_entry_is_a_miss_and_removed(tmp_path: Path) -> None:
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    assert DetectionCache(tmp_path).load("bad") is None
    assert not (tmp_path / "bad.npz").exists()


def test_cache_dir_default_and_env_override(monkeypatch: pytest.MonkeyPatch, tmp_path: Path):
    monkeypatch.delenv("GESTUREBANK_CACHE", raising=False)
    assert default_cache_dir() == Path(user_cache_dir("gesturebank")) / "detections"
    monkeypatch.setenv("GESTUREBANK_CACHE", str(tmp_path / "elsewhere"))
    assert default_cache_dir() == tmp_path / "elsewhere"
    assert DetectionCache().root == tmp_path / "elsewhere"
    assert DetectionCache(tmp_path / "arg").root == tmp_path / "arg"


def test_key_depends_on_video_detector_and_settings() -> None:
    base = cache_key("v1", "mediapipe", params={"min_detection_confidence": 0.5})
    assert base == cache_key("v1", "mediapipe", params={"min_detection_confidence": 0.5})
    assert base != cache_key("v2", "mediapipe", params={"min_detection_confidence": 0.5})
    assert base != cache_key("v1", "other", params={"min_detection_confidence": 0.5})
    assert base != cache_key("v1", "mediapipe", params={"min_detection_confidence": 0.4})


def test_small_file_digest_is_full_sha256_of_content(tmp_path: Path) -> None:
    a = tmp_path / "a.bin"
    data = np.random.default_rng(1).bytes(300_000)
    a.write_bytes(data)
    b = tmp_path / "b.bin"
    b.write_bytes(data)
    assert video_digest(a) == video_digest(b)  # content, not name
    flipped = bytearray(data)
    flipped[150_000] ^= 1
    b.write_bytes(bytes(flipped))
    assert video_digest(a) != video_digest(b)
    expected = hashlib.sha256(f"{len(data)}:sampled".encode() + data).hexdigest()
    assert video_digest(a) == expected


def test_large_file_digest_samples_head_tail_and_blocks(tmp_path: Path) -> None:
    size = 12 << 20
    data = bytearray(np.random.default_rng(2).bytes(size))
    path = tmp_path / "big.bin"
    path.write_bytes(bytes(data))
    d0 = video_digest(path)
    for offset in (10, size - 10):  # head and tail are always read
        changed = bytearray(data)
        changed[offset] ^= 1
        path.write_bytes(bytes(changed))
        assert video_digest(path) != d0
    path.write_bytes(bytes(data) + b"x")  # size is part of the digest
    assert video_digest(path) != d0
    path.write_bytes(bytes(data))
    assert video_digest(path) == d0 != video_digest(path, full=True)


class CountingDetector:
    """One fixed COCO-17 person per frame; counts its runs."""

    name = "counting"
    runs = 0

    def __init__(self, config: DetectorConfig | None = None, *, video: object = None) -> None:
        self.config = config

    def detect(self, frames):
        CountingDetector.runs += 1
        times, size = [], (1, 1)
        for t, image in frames:
            times.append(t)
            size = (image.shape[1], image.shape[0])
        kp = np.tile(np.linspace(0.1, 1, 51, dtype=np.float32).reshape(17, 3), (len(times), 1, 1))
        return Pose2D(kp, np.array(times), "coco17", size)


def test_pipeline_reuses_cached_detections(monkeypatch: pytest.MonkeyPatch, tmp_path: Path):
    monkeypatch.setitem(DETECTORS._factories, "counting", CountingDetector)
    monkeypatch.setattr(CountingDetector, "runs", 0)
    video = tmp_path / "v.mp4"
    with av.open(str(video), "w") as out:
        s = out.add_stream("libx264", rate=25)
        s.width, s.height, s.pix_fmt = 32, 32, "yuv420p"
        for i in range(4):
            f = av.VideoFrame.from_ndarray(np.zeros((32, 32, 3), np.uint8), "rgb24")
            f.pts, f.time_base = i, Fraction(1, 25)
            out.mux(s.encode(f))
        out.mux(s.encode())
    store = DetectionCache(tmp_path / "cache")
    config = Config()
    config.detector.name = "counting"
    first, again = (extract_take(video, config, cache=store) for _ in range(2))
    assert CountingDetector.runs == 1 and (first.info.cache_hit, again.info.cache_hit) == (
        False,
        True,
    )
    np.testing.assert_array_equal(first.multi.keypoints, again.multi.keypoints)
    np.testing.assert_array_equal(first.shots.change, again.shots.change)  # cached with them
    config.detector.blazepose.min_detection_confidence = 0.3  # another detector's setting
    assert extract_take(video, config, cache=store).info.cache_hit and CountingDetector.runs == 1
    config.video.stride = 2  # other frames: detect again
    extract_take(video, config, cache=store)
    config.shots.threshold = 20.0  # other shot cuts: detect again
    extract_take(video, config, cache=store)
    monkeypatch.setattr(CountingDetector, "version", 2, raising=False)  # new detector code
    extract_take(video, config, cache=store)
    config.build.cache_detections = False
    extract_take(video, config, cache=store)
    assert CountingDetector.runs == 5
