"""Every bad input is one InputError/DetectionError line naming the file; no audio is fine."""

from __future__ import annotations

import json
import shutil
from fractions import Fraction
from pathlib import Path

import av
import numpy as np
import pytest

from gesturebank.app.extract import extract_take
from gesturebank.config import Config
from gesturebank.errors import DetectionError, GesturebankError, InputError
from gesturebank.extract.cache import DetectionCache


def run(path: Path, tmp_path: Path, config: Config | None = None):
    return extract_take(path, config or Config(), cache=DetectionCache(tmp_path / "cache"))


def assert_one_line_naming(err: pytest.ExceptionInfo[GesturebankError], path: Path) -> None:
    msg = str(err.value)
    assert str(path) in msg and "\n" not in msg


def write_video(path: Path, frames: list[np.ndarray], fps: int = 25) -> None:
    h, w = frames[0].shape[:2]
    with av.open(str(path), "w") as out:
        s = out.add_stream("libx264", rate=fps)
        s.width, s.height, s.pix_fmt = w, h, "yuv420p"
        for i, img in enumerate(frames):
            f = av.VideoFrame.from_ndarray(img, "rgb24")
            f.pts, f.time_base = i, Fraction(1, fps)
            out.mux(s.encode(f))
        out.mux(s.encode())


@pytest.fixture
def cam01(samples: Path) -> Path:
    return samples / "pose2sim" / "Demo_SinglePerson" / "videos" / "cam01.mp4"


def test_truncated_file_with_index_at_the_end(tmp_path: Path, cam01: Path) -> None:
    # cam01's index (moov) follows the data: cutting the file loses it.
    path = tmp_path / "cut.mp4"
    path.write_bytes(cam01.read_bytes()[: cam01.stat().st_size // 2])
    with pytest.raises(InputError) as err:
        run(path, tmp_path)
    assert_one_line_naming(err, path)


def test_truncated_file_with_index_first(tmp_path: Path, samples: Path) -> None:
    # The demo's index comes first: FFmpeg decodes half the frames and stops silently.
    demo = samples / "sports2d" / "Demo" / "demo.mp4"
    path = tmp_path / "cut_demo.mp4"
    path.write_bytes(demo.read_bytes()[: demo.stat().st_size // 2])
    with pytest.raises(InputError, match="truncated") as err:
        run(path, tmp_path)
    assert_one_line_naming(err, path)


def test_corrupt_payload(tmp_path: Path, cam01: Path) -> None:
    """Every compressed frame garbage: nothing usable decodes, so the take fails."""
    data = bytearray(cam01.read_bytes())
    start = data.find(b"mdat") + 2000
    end = data.find(b"moov")  # keep the index: only the compressed frames are garbage
    data[start:end] = np.random.default_rng(0).bytes(end - start)
    path = tmp_path / "garbled.mp4"
    path.write_bytes(bytes(data))
    with pytest.raises((InputError, DetectionError)) as err:
        run(path, tmp_path)
    assert_one_line_naming(err, path)


def test_a_damaged_middle_keeps_the_stretches_that_decode(
    tmp_path: Path, cam01: Path, samples: Path
) -> None:
    """128 KiB overwritten in the middle of cam01's media data: 70 of its 100 frames still
    decode. The take builds; each intact stretch is judged on its own and the one long enough
    is a clip; the damaged span is named in the take's record."""
    from gesturebank.app.build import build_dataset
    from gesturebank.config import ClipsConfig
    from gesturebank.datasets.takes import discover_takes

    data = bytearray(cam01.read_bytes())
    start, end = data.find(b"mdat"), data.find(b"moov")
    middle = (start + end) // 2
    data[middle : middle + 128 * 1024] = np.random.default_rng(0).bytes(128 * 1024)
    take = tmp_path / "videos" / "lab"
    take.mkdir(parents=True)
    (take / "damaged.mp4").write_bytes(bytes(data))
    shutil.copy(samples / "speech" / "arctic_a0007.wav", take / "damaged.wav")
    config = Config(clips=ClipsConfig(min_s=0.5))  # cam01 lasts 1.7 s
    out = tmp_path / "out"
    summary = build_dataset(
        discover_takes(tmp_path / "videos"), videos_dir=tmp_path / "videos", out=out, config=config
    )
    assert not summary.failed, summary.failed[0].reason
    record = json.loads((out / "takes" / "lab__damaged.json").read_text())
    clips = [c for c in record["clips"] if c["kind"] == "clip"]
    damaged = [r for c in record["clips"] for r in c["qc_reasons"] if "no video frames" in r]
    assert clips and clips[0]["end_s"] < 1.0  # the stretch before the damage
    assert len(damaged) == 1 and damaged[0].endswith("s (damaged or missing)"), damaged


@pytest.mark.parametrize("content", [b"", np.random.default_rng(1).bytes(50_000)])
def test_empty_or_random_bytes(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "noise.mp4"
    path.write_bytes(content)
    with pytest.raises(InputError) as err:
        run(path, tmp_path)
    assert_one_line_naming(err, path)


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "nowhere.mp4"
    with pytest.raises(InputError) as err:
        run(path, tmp_path)
    assert_one_line_naming(err, path)


def test_audio_only_containers(tmp_path: Path, samples: Path) -> None:
    wav = tmp_path / "speech.mp4"  # a .wav under a video name
    shutil.copy(samples / "speech" / "arctic_a0007.wav", wav)
    m4a = tmp_path / "tone.m4a"
    with av.open(str(m4a), "w") as out:
        a = out.add_stream("aac", rate=16000, layout="mono")
        pcm = (np.sin(np.arange(16000) / 10) * 3000).astype(np.int16)
        for i in range(0, 16000, 1024):
            f = av.AudioFrame.from_ndarray(pcm[None, i : i + 1024], format="s16", layout="mono")
            f.sample_rate, f.pts, f.time_base = 16000, i, Fraction(1, 16000)
            out.mux(a.encode(f))
        out.mux(a.encode())
    for path in (wav, m4a):
        with pytest.raises(InputError, match="no video stream") as err:
            run(path, tmp_path)
        assert_one_line_naming(err, path)


def test_zero_frames(tmp_path: Path) -> None:
    empty = tmp_path / "empty_track.mp4"
    with av.open(str(empty), "w") as out:
        s = out.add_stream("libx264", rate=25)
        s.width, s.height, s.pix_fmt = 32, 32, "yuv420p"
        out.start_encoding()  # header only, no frames
    with pytest.raises(InputError) as err:
        run(empty, tmp_path)
    assert_one_line_naming(err, empty)
    # A real video, but the selected time range holds no frame.
    short = tmp_path / "short.mp4"
    write_video(short, [np.zeros((32, 32, 3), np.uint8)] * 5)
    config = Config()
    config.video.start_s = 10.0
    with pytest.raises(InputError, match="no decodable video frames") as err:
        run(short, tmp_path, config)
    assert_one_line_naming(err, short)


def test_no_person_in_any_frame(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    frames = [rng.integers(0, 255, (96, 128, 3), dtype=np.uint8) for _ in range(8)]
    path = tmp_path / "nobody.mp4"
    write_video(path, frames)
    with pytest.raises(DetectionError, match="no person") as err:
        run(path, tmp_path)
    assert_one_line_naming(err, path)


def test_unsupported_detector_name(tmp_path: Path, cam01: Path) -> None:
    config = Config()
    config.detector.name = "openpose-binary"
    with pytest.raises(InputError, match="openpose-binary") as err:
        run(cam01, tmp_path, config)
    assert_one_line_naming(err, cam01)
    assert "mediapipe" in str(err.value)  # says what is available


def test_missing_keypoint_folder_is_named(tmp_path: Path, cam01: Path) -> None:
    video = tmp_path / "cam01.mp4"
    shutil.copy(cam01, video)
    config = Config()
    config.detector.name = "openpose-json"
    with pytest.raises(InputError) as err:
        run(video, tmp_path, config)
    assert_one_line_naming(err, video)
    assert "cam01_json" in str(err.value)


def test_video_without_audio_is_allowed(tmp_path: Path, cam01: Path) -> None:
    config = Config()
    config.video.end_s = 0.2  # 12 frames are enough
    ext = run(cam01, tmp_path, config)
    pose, audio, info = ext.tracked.pose, ext.audio, ext.info
    assert audio is None and info.audio_source is None and not info.video.has_audio
    # 0.2 s of 60 fps footage, detected at most 30 times a second: every second frame
    assert len(pose) == 6 and info.main_fraction == 1.0


def test_wav_beside_the_video_supplies_the_audio(tmp_path: Path, cam01: Path, samples: Path):
    video = tmp_path / "cam01.mp4"
    shutil.copy(cam01, video)
    shutil.copy(samples / "speech" / "arctic_a0007.wav", tmp_path / "cam01.wav")
    config = Config()
    config.video.end_s = 0.1
    ext = run(video, tmp_path, config)
    audio, info = ext.audio, ext.info
    assert audio is not None and info.audio_source == str(tmp_path / "cam01.wav")
    assert audio.sample_rate == 16000 and len(audio.signal) == 64000  # 4.0 s at 16 kHz
    assert audio.start_s == 0.0 and audio.start_offset_s == 0.0
