"""Derived real footage: the standard set's sizes, rates, clocks, speech, cut and cache."""

from __future__ import annotations

import os
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np
import pytest

from gesturebank import footage
from gesturebank.audio.io import read_audio
from gesturebank.extract.video import frame_timestamps, probe
from gesturebank.footage import (
    CAM01,
    CAM03,
    MULTI_CAM,
    SPEECH,
    WAIST_UP_BOX,
    Frames,
    Recipe,
    make_footage,
    make_take,
)

SCALE = 0.03  # every take 3 % of its real length: 10 s -> 18 frames at 60 fps, 60 s -> 108
AAC_FRAME_S = 1024 / 16000


def decode(path: Path) -> list[np.ndarray]:
    with av.open(str(path)) as container:
        return [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = np.mean((a.astype(np.float64) - b) ** 2)
    return float(10 * np.log10(255.0**2 / mse))


@pytest.fixture(scope="module")
def standard_set(samples, tmp_path_factory) -> dict[str, Path]:
    return make_footage(samples, tmp_path_factory.mktemp("footage"), time_scale=SCALE)


def expected(samples: Path) -> dict[str, tuple[tuple[int, int], int, int]]:
    """name -> (size, fps, frames) at SCALE."""
    table = {
        "long60": ((1080, 1920), 60, 108),
        "fps60": ((1080, 1920), 60, 18),
        "fps30": ((1080, 1920), 30, 9),
        "waist_up": ((1080, 720), 60, 18),
        "cut": ((1080, 1920), 60, 18),
        "crossing": ((1768, 994), 30, 7),  # 7.67 s × 0.03 at 30 fps
        "lowres": ((202, 360), 60, 18),  # 1080 × 360 / 1920 = 202.5 -> even 202
        "behind": ((720, 480), 60, 18),  # cam02's waist-up box (issue 41)
    }
    if (samples / MULTI_CAM).is_file():
        table["multi"] = (probe(samples / MULTI_CAM).size, 60, 18)
    return table


def test_the_standard_set_is_made_of_every_take_whose_clip_exists(samples, standard_set) -> None:
    assert set(standard_set) == set(expected(samples))
    assert all(path.is_file() and path.suffix == ".mp4" for path in standard_set.values())


def test_sizes_rates_frame_counts_and_a_real_clock(samples, standard_set) -> None:
    for name, (size, fps, n) in expected(samples).items():
        path = standard_set[name]
        info = probe(path)
        assert (info.size, info.fps, info.codec) == (size, fps, "h264"), name
        with av.open(str(path)) as container:
            assert container.streams.video[0].codec_context.pix_fmt == "yuv420p"
        times = frame_timestamps(path)
        assert len(times) == n, name
        assert np.all(np.diff(times) > 0), name
        np.testing.assert_allclose(times, np.arange(n) / fps, atol=1e-6, err_msg=name)
        assert info.duration_s == pytest.approx(n / fps, abs=1e-6), name


def test_every_take_has_the_looped_speech_as_long_as_the_video(samples, standard_set) -> None:
    for name, path in standard_set.items():
        n = len(frame_timestamps(path))
        video_s = n / probe(path).fps
        audio = read_audio(path, sample_rate=16000)
        assert audio is not None and audio.sample_rate == 16000, name
        assert audio.start_offset_s == pytest.approx(0.0, abs=1e-6), name
        audio_s = len(audio.signal) / audio.sample_rate
        assert video_s <= audio_s <= video_s + AAC_FRAME_S, name  # AAC pads its last frame
        speech = footage.looped_speech([samples / p for p in SPEECH], seconds=video_s)
        assert np.corrcoef(audio.signal[: len(speech)], speech)[0, 1] > 0.99, name


def test_long_take_loops_past_the_source_and_speech_past_one_sentence(standard_set) -> None:
    """108 frames of a 100-frame clip: frames 100, 101 … are cam01's 98, 97 … (ping-pong), and
    1.8 s of the 4 s + 3.1 s speech is one sentence; at full scale 60 s loops both."""
    frames = decode(standard_set["long60"])
    assert psnr(frames[100], frames[96]) > psnr(frames[100], frames[90])
    assert psnr(frames[101], frames[97]) > 40  # backward: frame 101 shows source frame 97
    steps = [np.mean(np.abs(frames[i].astype(np.int16) - frames[i - 1])) for i in range(1, 108)]
    assert max(steps[95:105]) < 2 * np.median(steps)  # no jump at the turning point


def test_fps30_frames_are_every_second_frame_of_fps60(standard_set) -> None:
    fast, slow = decode(standard_set["fps60"]), decode(standard_set["fps30"])
    assert len(fast) == 2 * len(slow)
    np.testing.assert_allclose(
        frame_timestamps(standard_set["fps30"]), frame_timestamps(standard_set["fps60"])[::2]
    )
    for i, img in enumerate(slow):
        same, neighbour = psnr(img, fast[2 * i]), psnr(img, fast[2 * i + 1])
        assert same > 40.0  # equal up to codec loss (measured 44–46 dB)
        assert same > neighbour + 5.0  # and not merely similar (the next frame: 33–35 dB)


def test_waist_up_is_the_head_to_hips_crop_of_cam01(samples, standard_set) -> None:
    x0, y0, x1, y1 = WAIST_UP_BOX
    source = footage.load(samples / CAM01, seconds=0.1).images[0]
    assert psnr(decode(standard_set["waist_up"])[0], source[y0:y1, x0:x1]) > 40.0


def test_lowres_is_cam01_shrunk_with_its_aspect(samples, standard_set) -> None:
    source = footage.load(samples / CAM01, seconds=0.1).images[0]
    small = cv2.resize(source, (202, 360), interpolation=cv2.INTER_AREA)
    # 4:2:0 halves the colour resolution, which costs more on a small frame (measured 35.5 dB).
    assert psnr(decode(standard_set["lowres"])[0], small) > 33.0


def test_cut_switches_from_cam01_to_cam03_at_its_time(samples, standard_set) -> None:
    frames = decode(standard_set["cut"])
    cut = round(5 * SCALE * 60)  # first frame of cam03
    steps = [np.mean(np.abs(frames[i].astype(np.int16) - frames[i - 1])) for i in range(1, 18)]
    assert abs(int(np.argmax(steps)) + 1 - cut) <= 1
    cam01 = footage.load(samples / CAM01, seconds=0.1).images[0]
    cam03 = cv2.resize(footage.load(samples / CAM03, seconds=0.1).images[0], (1080, 1920))
    assert psnr(frames[0], cam01) > 40.0 and psnr(frames[cut], cam03) > 35.0
    assert psnr(frames[cut], cam01) < 20.0


def test_a_second_call_writes_nothing(samples, standard_set) -> None:
    folder = next(iter(standard_set.values())).parent

    def state() -> dict[str, tuple[int, int]]:
        return {p.name: (p.stat().st_mtime_ns, p.stat().st_size) for p in folder.iterdir()}

    before = state()
    assert make_footage(samples, folder, time_scale=SCALE) == standard_set
    assert state() == before
    assert {p.suffix for p in folder.iterdir()} == {".mp4", ".json"}  # no temporary left over
    assert not any(name.startswith(".") for name in before)


def test_a_take_is_remade_when_its_recipe_or_record_changes(samples, tmp_path) -> None:
    out = tmp_path / "small.mp4"
    recipe = Recipe((CAM01,), (0.05,), height=360)
    assert make_take(recipe, samples=samples, out=out)
    assert not make_take(recipe, samples=samples, out=out)
    assert make_take(Recipe((CAM01,), (0.1,), height=360), samples=samples, out=out)
    assert len(frame_timestamps(out)) == 6
    out.with_suffix(".json").unlink()  # e.g. killed after the video, before its record
    assert make_take(Recipe((CAM01,), (0.1,), height=360), samples=samples, out=out)


def test_takes_whose_sample_clip_is_absent_are_skipped(samples, tmp_path) -> None:
    partial = tmp_path / "samples"
    for rel in (CAM01, *SPEECH):
        (partial / rel).parent.mkdir(parents=True, exist_ok=True)
        os.symlink(samples / rel, partial / rel)
    made = make_footage(partial, tmp_path / "out", time_scale=0.005)
    assert set(made) == {"long60", "fps60", "fps30", "waist_up", "lowres"}


# -- the in-memory transforms ----------------------------------------------------------------


def numbered(n: int, fps: int = 60) -> Frames:
    """n tiny frames whose pixels are their index."""
    return Frames(tuple(np.full((4, 6, 3), i, np.uint8) for i in range(n)), Fraction(fps))


def order(frames: Frames) -> list[int]:
    return [int(img[0, 0, 0]) for img in frames.images]


def test_ping_pong_turns_without_repeating_a_frame() -> None:
    assert order(footage.ping_pong(numbered(4), seconds=11 / 60)) == [
        0, 1, 2, 3, 2, 1, 0, 1, 2, 3, 2,
    ]  # fmt: skip
    assert order(footage.ping_pong(numbered(1), seconds=3 / 60)) == [0, 0, 0]
    assert order(footage.ping_pong(numbered(5), seconds=2 / 60)) == [0, 1]
    with pytest.raises(ValueError, match="less than one frame"):
        footage.ping_pong(numbered(4), seconds=0.001)


def test_ping_pong_shares_the_source_images() -> None:
    long = footage.ping_pong(numbered(3), seconds=1.0)
    assert len(long.images) == 60 and len({id(img) for img in long.images}) == 3
    shrunk = footage.rescale(long, size=(2, 2))
    assert len({id(img) for img in shrunk.images}) == 3  # transformed once per source frame


def test_keep_every_divides_the_rate() -> None:
    half = footage.keep_every(numbered(7), k=2)
    assert order(half) == [0, 2, 4, 6] and half.fps == 30


def test_rescale_keeps_the_aspect_with_an_even_width() -> None:
    frames = Frames((np.zeros((1920, 1080, 3), np.uint8),), Fraction(60))
    assert footage.rescale(frames, height=360).size == (202, 360)
    assert footage.rescale(frames, size=(1088, 1920)).size == (1088, 1920)


def test_bad_transforms_are_refused() -> None:
    with pytest.raises(ValueError, match="not inside"):
        footage.crop(numbered(2), box=(0, 0, 7, 4))
    with pytest.raises(ValueError, match="does not match"):
        footage.concat([numbered(2), numbered(2, fps=30)])
    with pytest.raises(ValueError, match="every image"):
        Frames((np.zeros((4, 6, 3), np.uint8), np.zeros((4, 8, 3), np.uint8)), Fraction(30))


def test_an_odd_frame_size_is_refused_before_anything_is_written(tmp_path) -> None:
    odd = Frames((np.zeros((5, 6, 3), np.uint8),), Fraction(30))
    with pytest.raises(ValueError, match="even frame size"):
        footage.write(odd, tmp_path / "odd.mp4", speech=np.zeros(0))
    assert list(tmp_path.iterdir()) == []
