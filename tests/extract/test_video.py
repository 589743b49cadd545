"""Video decoding: real timestamps (VFR), rotation, stride/range, decode threads."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import av
import numpy as np
import pytest

from gesturebank.config import VideoConfig
from gesturebank.extract.video import (
    frame_timestamps,
    iter_frames,
    probe,
    select_indices,
)

# Irregular presentation times in milliseconds (a phone's variable frame rate, exaggerated).
VFR_MS = [0, 33, 50, 120, 121, 300, 301, 302, 450, 1000, 1017, 1400]


def write_video(
    path: Path,
    pts_ms: list[int],
    size: tuple[int, int] = (64, 48),
    *,
    rotation: int | None = None,
) -> None:
    """H.264 video whose frame i is uniformly grey level 20 * i, at the given pts (1/1000 s)."""
    w, h = size
    with av.open(str(path), "w") as out:
        stream = out.add_stream("libx264", rate=30)
        stream.width, stream.height, stream.pix_fmt = w, h, "yuv420p"
        stream.time_base = Fraction(1, 1000)
        stream.codec_context.time_base = Fraction(1, 1000)
        if rotation is not None:
            stream.set_display_rotation(rotation)
        for i, ms in enumerate(pts_ms):
            img = np.full((h, w, 3), 20 * i, np.uint8)
            if rotation is not None:
                img[: h // 4, : w // 4] = 255  # white marker in the coded top-left corner
                img[h // 4 :, :] = 0
                img[:, w // 4 :] = 0
            frame = av.VideoFrame.from_ndarray(img, format="rgb24")
            frame.pts, frame.time_base = ms, Fraction(1, 1000)
            out.mux(stream.encode(frame))
        out.mux(stream.encode())


def test_variable_frame_rate_timestamps_are_kept_exactly(tmp_path: Path) -> None:
    path = tmp_path / "vfr.mp4"
    write_video(path, VFR_MS)
    got = list(iter_frames(path, VideoConfig(max_fps=None)))
    np.testing.assert_allclose([t for t, _ in got], np.array(VFR_MS) / 1000, rtol=0, atol=1e-9)
    # Each timestamp stays with its own picture (grey level 20 * i).
    levels = [float(img.mean()) for _, img in got]
    np.testing.assert_allclose(levels, 20 * np.arange(len(VFR_MS)), atol=3)
    np.testing.assert_allclose(frame_timestamps(path), np.array(VFR_MS) / 1000, atol=1e-9)


def test_frames_are_rgb_uint8_and_streamed(tmp_path: Path) -> None:
    path = tmp_path / "vfr.mp4"
    write_video(path, VFR_MS, size=(64, 48))
    frames = iter_frames(path)
    assert iter(frames) is frames  # a generator, not a list
    t, img = next(frames)
    assert t == 0.0 and img.shape == (48, 64, 3) and img.dtype == np.uint8


def test_stride_and_time_range(tmp_path: Path) -> None:
    path = tmp_path / "vfr.mp4"
    write_video(path, VFR_MS)
    got = [
        t for t, _ in iter_frames(path, VideoConfig(start_s=0.1, end_s=0.5, stride=2, max_fps=None))
    ]
    # In [100, 500) ms: 120, 121, 300, 301, 302, 450 → every 2nd: 120, 300, 302.
    np.testing.assert_allclose(got, [0.120, 0.300, 0.302], atol=1e-9)
    later = [t for t, _ in iter_frames(path, VideoConfig(start_s=1.0, max_fps=None))]
    np.testing.assert_allclose(later, [1.0, 1.017, 1.4], atol=1e-9)


def test_max_fps_keeps_a_regular_subset_on_the_real_clock(tmp_path: Path) -> None:
    """A frame is kept when 0.75 / max_fps has passed since the last kept one: 60 fps footage
    keeps every second frame at 30, VFR footage the frames that are far enough apart."""
    path = tmp_path / "vfr.mp4"
    write_video(path, VFR_MS)
    got = [t for t, _ in iter_frames(path, VideoConfig(max_fps=30.0))]
    # 0, 33, 50, 120, 121, 300, 301, 302, 450, 1000, 1017, 1400 ms, steps ≥ 25 ms kept
    np.testing.assert_allclose(got, [0.0, 0.033, 0.12, 0.3, 0.45, 1.0, 1.4], atol=1e-9)
    ts = np.array(VFR_MS) / 1000
    np.testing.assert_array_equal(ts[select_indices(ts, VideoConfig(max_fps=30.0))], got)
    sixty = np.arange(120) / 60
    kept = select_indices(sixty, VideoConfig(max_fps=30.0))
    np.testing.assert_array_equal(kept, np.arange(0, 120, 2))
    assert len(select_indices(np.arange(90) / 30, VideoConfig(max_fps=30.0))) == 90


def test_rotation_metadata_is_applied(tmp_path: Path) -> None:
    path = tmp_path / "rot.mp4"
    # PyAV's convention: -90 = rotate 90° clockwise for display (a phone held upright).
    write_video(path, [0, 33, 66], size=(64, 32), rotation=-90)
    info = probe(path)
    assert info.size == (32, 64)
    _, img = next(iter_frames(path))
    assert img.shape == (64, 32, 3)
    grey = img.mean(axis=2)
    # Clockwise turn: the coded top-left corner is now the top-right corner.
    assert grey[:8, -8:].mean() > 200
    assert grey[:8, :8].mean() < 50 and grey[-8:, -8:].mean() < 50


def test_probe_and_decode_real_videos(samples: Path) -> None:
    cam01 = samples / "pose2sim" / "Demo_SinglePerson" / "videos" / "cam01.mp4"
    info = probe(cam01)
    assert info.size == (1080, 1920) and info.n_frames == 100 and info.codec == "h264"
    assert info.fps == pytest.approx(60) and not info.has_audio
    ts = [t for t, img in iter_frames(cam01, VideoConfig(stride=10))]
    np.testing.assert_allclose(ts, np.arange(0, 100, 10) / 60, atol=1e-6)
    demo = probe(samples / "sports2d" / "Demo" / "demo.mp4")
    assert demo.size == (1768, 994) and demo.n_frames == 230 and demo.codec == "vp9"
    assert demo.duration_s == pytest.approx(230 / 30, abs=0.05)


@pytest.mark.parametrize(
    "clip", ["pose2sim/Demo_SinglePerson/videos/cam01.mp4", "sports2d/Demo/demo.mp4"]
)
def test_decode_threads_give_the_same_frames(samples: Path, clip: str) -> None:
    """Frame threads (h264) and slice threads (vp9) only change the speed, never a pixel."""
    window = VideoConfig(end_s=0.5)
    single = list(iter_frames(samples / clip, window, threads=1))
    assert len(single) >= 15
    for threads in (None, 2):
        many = list(iter_frames(samples / clip, window, threads=threads))
        assert [t for t, _ in many] == [t for t, _ in single]
        for (_, a), (_, b) in zip(many, single, strict=True):
            np.testing.assert_array_equal(a, b)


def test_large_frames_wait_at_most_two_ahead_of_their_consumer() -> None:
    """Issue 43: decoded frames queued ahead of the detector are bounded in bytes too, so a 4K
    UHD video (25 MB a frame) holds 2 of them per worker, not 8 (a 1080p one still holds 8)."""
    import threading

    from gesturebank.extract.video import PREFETCH, prefetched

    def source(shape: tuple[int, ...], pulled: list[int], full: threading.Event):
        for i in range(20):
            pulled.append(i)
            if len(pulled) > 2:
                full.set()
            yield float(i), np.zeros(shape, np.uint8)

    for shape, ahead in (((2160, 3840, 3), 2), ((1080, 1920, 3), PREFETCH)):
        pulled: list[int] = []
        full = threading.Event()
        frames = prefetched(source(shape, pulled, full))
        next(frames)
        full.wait(5)
        for _ in range(100):  # until the producer is blocked on the full queue
            before = len(pulled)
            threading.Event().wait(0.02)
            if len(pulled) == before:
                break
        # the consumer's frame, the queue, and the one the producer holds waiting for room
        assert len(pulled) == 1 + ahead + 1
        frames.close()


def test_a_stream_is_converted_to_rgb_without_starting_threads_for_each_frame(
    samples: Path,
) -> None:
    """Issue 43: `frame.to_ndarray(format="rgb24")` makes a swscale context for every frame and
    starts and stops its threads (one per core) for that frame: 3-4 ms of CPU a frame where one
    context kept for the stream takes under 1. The pixels are `to_ndarray`'s."""
    import threading

    clip = samples / "sports2d" / "Demo" / "demo.mp4"
    seen: set[int] = set()
    stop = threading.Event()

    def watch() -> None:
        while not stop.wait(0.0005):
            seen.update(int(task.name) for task in Path("/proc/self/task").iterdir())

    if not Path("/proc/self/task").is_dir():
        pytest.skip("needs /proc")
    before = {int(task.name) for task in Path("/proc/self/task").iterdir()}
    watcher = threading.Thread(target=watch)
    watcher.start()
    try:
        frames = list(iter_frames(clip, VideoConfig(end_s=1.0), threads=1))
    finally:
        stop.set()
        watcher.join()
    assert len(frames) >= 30
    started = seen - before  # the watcher, the stream's swscale threads
    assert len(started) <= 4, f"{len(started)} threads started decoding {len(frames)} frames"
    with av.open(str(clip)) as container:
        for (_, ours), frame in zip(frames, container.decode(video=0), strict=False):
            np.testing.assert_array_equal(ours, frame.to_ndarray(format="rgb24"))
