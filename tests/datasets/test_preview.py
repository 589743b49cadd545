"""`gesturebank preview`: the speaker's video beside the robot render, on one clock, with audio."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import av
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gesturebank import datasets
from gesturebank.audio.io import read_audio
from gesturebank.config import PlaybackConfig, RenderConfig, RobotConfig
from gesturebank.datasets.preview import (
    BONE,
    CODE_BITS,
    crop_box,
    draw_frame_code,
    preview_clip,
    read_frame_code,
)
from gesturebank.errors import InputError

BIN = Path(sys.executable).parent
RENDER = RenderConfig(width_px=320, height_px=240, frame_rate=12)  # small and few: a fast test


def _write(dataset: Path, clip_id: str, out: Path) -> Path:
    return preview_clip(
        dataset,
        clip_id=clip_id,
        out=out,
        render=RENDER,
        playback=PlaybackConfig(),
        profile=RobotConfig().profile,
    )


def _source_times(video: Path) -> np.ndarray:
    """Every frame's presentation time in the source, read here with PyAV, sorted."""
    with av.open(str(video)) as container:
        stream = container.streams.video[0]
        tb = stream.time_base
        return np.unique([float(p.pts * tb) for p in container.demux(stream) if p.pts is not None])


def test_preview_shows_person_and_robot_on_one_clock_with_audio(
    demo_dataset: Path, tmp_path: Path
) -> None:
    ds = datasets.open(demo_dataset)
    row = ds.clips("accepted")[0]
    clip = ds.load(row.clip.clip_id)
    out = _write(demo_dataset, row.clip.clip_id, tmp_path / "clip.mp4")

    fps = RENDER.frame_rate
    codes, drawn = [], []
    with av.open(str(out)) as container:
        assert container.streams.audio, "no audio stream in the preview"
        for frame in container.decode(video=0):
            img = frame.to_ndarray(format="rgb24")
            assert img.shape == (RENDER.height_px, 2 * RENDER.width_px, 3)
            half = RENDER.width_px
            codes.append((read_frame_code(img[:, :half]), read_frame_code(img[:, half:])))
            bone = np.abs(img.astype(int) - BONE).max(axis=-1) < 40  # the skeleton's colour
            drawn.append((bone[:, :half].sum(), bone[:, half:].sum()))
    with av.open(str(out)) as container:
        sound = np.concatenate([f.to_ndarray()[0] for f in container.decode(audio=0)])
        audio_rate = container.streams.audio[0].rate

    # the speaker's keypoints are drawn on the left, never on the robot
    left_px, right_px = np.array(drawn).T
    assert np.mean(left_px > 100) > 0.9 and right_px.max() == 0, (left_px.min(), right_px.max())

    # the durations agree within one frame
    assert abs(len(codes) / fps - clip.duration_s) <= 1 / fps
    assert abs(len(sound) / audio_rate - clip.duration_s) <= 1 / fps

    # frame k: the left half shows the source frame at or before clip time k / fps, the right
    # half the clip's 100 Hz frame at or before it — the same moment within one frame
    source = Path(ds.info.videos_dir) / row.take.source
    times = _source_times(source) - clip.start_s
    period = float(np.median(np.diff(times)))
    left = np.array([times[a] for a, _ in codes])
    right = np.array([clip.times[b] for _, b in codes])
    clock = np.arange(len(codes)) / fps
    assert np.all((clock - left > -1e-3) & (clock - left < period + 1e-3)), (clock - left).max()
    assert np.all((clock - right > -1e-3) & (clock - right < 0.01 + 1e-3))
    assert np.abs(left - right).max() < 1 / fps

    # the audio is the source's from the clip's start: best aligned at lag 0 (± 2 ms)
    track = read_audio(source, sample_rate=audio_rate)
    assert track is not None
    first = round((clip.start_s - track.start_s) * audio_rate)
    ref = track.signal[first : first + len(sound)]
    n = min(len(ref), len(sound))
    lags = range(-800, 801, 8)
    corr = [float(np.dot(sound[800 : n - 800], ref[800 + g : n - 800 + g])) for g in lags]
    best = list(lags)[int(np.argmax(corr))]
    assert abs(best) <= 32, best
    norm = np.linalg.norm(sound[800 : n - 800]) * np.linalg.norm(ref[800 : n - 800])
    assert max(corr) / norm > 0.9


def test_an_unknown_clip_names_the_nearest_ids(demo_dataset: Path, tmp_path: Path) -> None:
    clip_id = datasets.open(demo_dataset).clip_ids(None)[0]
    take_id = clip_id.rsplit("__", 1)[0]
    for wrong in (take_id, clip_id[:-1] + "9"):
        with pytest.raises(InputError) as err:
            _write(demo_dataset, wrong, tmp_path / "x.mp4")
        message = str(err.value)
        assert "\n" not in message
        assert repr(wrong) in message and clip_id in message
    assert not (tmp_path / "x.mp4").exists()


@given(st.integers(0, 2**CODE_BITS - 1), st.integers(0, 2**32 - 1))
def test_the_frame_code_survives_noise(value: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    img = rng.integers(0, 256, (240, 320, 3), dtype=np.uint8)
    draw_frame_code(img, value)
    noisy = np.clip(img.astype(int) + rng.integers(-40, 41, img.shape), 0, 255)
    assert read_frame_code(noisy) == value


@given(
    st.lists(st.tuples(st.floats(-50, 1100), st.floats(-50, 1950)), min_size=1, max_size=40),
    st.sampled_from([4 / 3, 1.0, 16 / 9, 0.5]),
)
def test_the_crop_box_stays_in_the_image_and_keeps_the_points(
    points: list[tuple[float, float]], aspect: float
) -> None:
    size = (1080, 1920)
    xy = np.array(points)
    x0, y0, x1, y1 = crop_box(xy, image_size=size, aspect=aspect)
    assert 0 <= x0 < x1 <= size[0] and 0 <= y0 < y1 <= size[1]
    inside = np.clip(xy, 0, [size[0], size[1]])
    core_lo, core_hi = np.percentile(inside, 1, axis=0), np.percentile(inside, 99, axis=0)
    assert x0 <= core_lo[0] + 1 and core_hi[0] <= x1 + 1
    assert y0 <= core_lo[1] + 1 and core_hi[1] <= y1 + 1
    w, h = x1 - x0, y1 - y0
    if w < size[0] and h < size[1]:  # nothing clipped by the image: the aspect is met
        assert w / h == pytest.approx(aspect, rel=0.02, abs=2 / h)


def test_the_cli_writes_a_take_and_refuses_a_wrong_one(demo_dataset: Path, tmp_path: Path) -> None:
    clip_id = datasets.open(demo_dataset).clip_ids(None)[-1]
    take_id = clip_id.rsplit("__", 1)[0]
    tiny = ["--set", "render.width_px=96", "--set", "render.height_px=72"]
    cmd = [str(BIN / "gesturebank"), "preview", str(demo_dataset), *tiny]
    ok = subprocess.run(
        [*cmd, "--take", take_id, "--out", str(tmp_path / "take")],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert ok.returncode == 0, ok.stderr
    assert (tmp_path / "take" / f"{clip_id}.mp4").stat().st_size > 0
    bad = subprocess.run(
        [*cmd, "--take", take_id[:-1], "--out", str(tmp_path / "bad")],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert bad.returncode == 2
    assert bad.stderr.count("\n") == 1 and take_id in bad.stderr, bad.stderr
    assert not (tmp_path / "bad").exists()


def test_the_frame_code_has_its_legend_beside_it() -> None:
    """Issue 44: the frame-code strip looked like a glitch until `preview --help` was read. Its
    legend is drawn beside it, and the code still reads back."""
    from gesturebank.datasets.preview import _annotate, _code_square

    panel = np.full((480, 640, 3), 128, np.uint8)
    _annotate(panel, "person", 1234, "video")
    assert read_frame_code(panel) == 1234
    s = _code_square(480, 640)
    beside = panel[480 - 3 * s :, CODE_BITS * s : CODE_BITS * s + 200]
    assert (beside != 128).any(axis=-1).sum() > 100  # text drawn right of the squares
