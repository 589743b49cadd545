"""Shot boundaries on real footage: hard cuts between real cameras, none in uncut real takes."""

from __future__ import annotations

import io
import sys
from collections.abc import Iterable, Iterator
from pathlib import Path

import av
import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from gesturebank import footage
from gesturebank.config import ShotsConfig
from gesturebank.errors import DetectionError
from gesturebank.extract.shots import INSTALL, ShotDetector, Shots, analysis_size, detect_shots
from gesturebank.extract.video import iter_frames

CLIPS = {f"cam0{i}": f"pose2sim/Demo_SinglePerson/videos/cam0{i}.mp4" for i in (1, 2, 3, 4)}
CLIPS["sports2d"] = "sports2d/Demo/demo.mp4"  # 30 fps; the Pose2Sim cameras 60 fps

Frame = tuple[float, np.ndarray]


def decoded(path: Path, *, step: int = 1) -> Iterator[Frame]:
    """(timestamp_s, RGB (H, W, 3)) of every step-th frame, on the file's own clock."""
    with av.open(str(path)) as container:
        for i, frame in enumerate(container.decode(video=0)):
            if i % step == 0:
                yield float(frame.pts * frame.time_base), frame.to_ndarray(format="rgb24")


def shrunk(frames: Iterable[Frame]) -> list[Frame]:
    """The frames at the detector's analysis size, shrunk as the detector itself does (so the
    detector's own resize is a no-op and its result is the same: see the test below). Keeps the
    decoded real clips small enough to hold for the whole module."""
    out = []
    for t, img in frames:
        size = analysis_size(img.shape[1], img.shape[0])
        out.append((t, cv2.resize(img, size, interpolation=cv2.INTER_LINEAR)))
    return out


@pytest.fixture(scope="module")
def clips(samples) -> dict[str, list[Frame]]:
    """Every frame of each uncut real sample clip, at the analysis size."""
    return {name: shrunk(decoded(samples / path)) for name, path in CLIPS.items()}


def after(first: list[Frame], second: list[Frame]) -> tuple[list[Frame], float]:
    """`second` played right after `first` (a hard cut), and the time of the cut."""
    cut_at = first[-1][0] + (first[-1][0] - first[-2][0])
    return first + [(cut_at + t - second[0][0], img) for t, img in second], cut_at


def clocked(parts: list[list[np.ndarray]], dt: list[float]) -> list[Frame]:
    """The images of the parts one after the other, image k shown dt[k] after image k - 1."""
    frames = [img for part in parts for img in part]
    times = np.concatenate([[0.0], np.cumsum(dt[1 : len(frames)])])
    return list(zip(times.tolist(), frames, strict=True))


def first_times(parts: list[list[np.ndarray]], times: list[float]) -> list[float]:
    """The time of the first frame of every part after the first."""
    starts = np.cumsum([len(p) for p in parts])[:-1]
    return [times[i] for i in starts]


# -- real hard cuts --------------------------------------------------------------------------


@pytest.mark.parametrize("second", ["cam03", "sports2d"])
@pytest.mark.parametrize("step", [1, 2], ids=["all-frames", "every-2nd"])
def test_hard_cut_between_two_real_cameras_is_found_on_its_frame(clips, second, step) -> None:
    """Every 2nd frame of 60 fps footage is what the pose detector sees at max_fps 30."""
    frames, cut_at = after(clips["cam01"][::step], clips[second][::step])
    shots = detect_shots(frames, ShotsConfig())
    period = frames[1][0] - frames[0][0]
    assert len(shots.cuts) == 1
    assert abs(shots.cuts[0] - cut_at) <= period + 1e-9  # ±1 analysed frame
    i = int(np.searchsorted(shots.timestamps, shots.cuts[0]))
    assert shots.change[i] > 1.5 * 27.0  # well above the threshold


def test_cut_in_an_encoded_take_is_found_through_the_decoder(samples, tmp_path) -> None:
    """The real path: a take written with libx264 (at half size, to be quick), decoded by
    iter_frames at its default rate cap (what the pose detector sees), then the shot detector."""
    parts = [
        footage.rescale(footage.load(samples / CLIPS[c], seconds=0.6), height=960)
        for c in ("cam01", "cam02")
    ]
    take = footage.write(footage.concat(parts), tmp_path / "cut.mp4", speech=np.zeros(0))
    shots = detect_shots(iter_frames(take), ShotsConfig())
    period = float(np.median(np.diff(shots.timestamps)))
    assert len(shots.cuts) == 1
    assert abs(shots.cuts[0] - 0.6) <= period + 1e-9


def test_shrinking_before_the_detector_changes_nothing(samples, clips) -> None:
    """Why the module may hold its clips shrunk: full-size frames give the same result."""
    full = detect_shots(decoded(samples / CLIPS["cam03"], step=2), ShotsConfig())
    small = detect_shots(clips["cam03"][::2], ShotsConfig())
    np.testing.assert_array_equal(full.change, small.change)
    np.testing.assert_array_equal(full.timestamps, small.timestamps)


# -- uncut real takes ------------------------------------------------------------------------


@pytest.mark.parametrize("clip", list(CLIPS))
@pytest.mark.parametrize("step", [1, 2], ids=["all-frames", "every-2nd"])
def test_no_cut_in_an_uncut_real_take(clips, clip, step) -> None:
    """Sports2D has camera shake, a second person walking past, a flip in the tree and sun flare
    flickering through it: its largest change (20 at 5.8 s) stays under the default 27."""
    shots = detect_shots(clips[clip][::step], ShotsConfig())
    assert shots.cuts.size == 0
    assert np.nanmax(shots.change) < 0.8 * 27.0


# -- min_shot_s and the clock ----------------------------------------------------------------


@pytest.fixture(scope="module")
def four_cameras(clips) -> list[list[np.ndarray]]:
    return [[img for _, img in clips[f"cam0{i}"][:60]] for i in (1, 2, 3, 4)]


def test_min_shot_s_drops_a_cut_too_close_to_the_last(four_cameras) -> None:
    """Shots of 60, 12, 24 and 60 frames at 60 fps: cuts at 1.0, 1.2 and 1.6 s."""
    a, b, c, d = four_cameras
    parts = [a, b[:12], c[:24], d]
    frames = clocked(parts, [1 / 60] * 156)
    truth = first_times(parts, [t for t, _ in frames])
    assert np.allclose(truth, [1.0, 1.2, 1.6])
    everything = detect_shots(frames, ShotsConfig(min_shot_s=0.0))
    np.testing.assert_allclose(everything.cuts, truth)
    # 1.2 is 0.2 s after the cut at 1.0: dropped; 1.6 is 0.6 s after it: kept. (PySceneDetect's
    # default flash filter, MERGE, would drop 1.6 as well.)
    np.testing.assert_allclose(detect_shots(frames, ShotsConfig()).cuts, [1.0, 1.6])


def test_first_shot_is_counted_from_the_first_frame(four_cameras) -> None:
    a, b, *_ = four_cameras
    frames = clocked([a[:20], b], [1 / 60] * 80)  # a cut at 0.33 s
    assert detect_shots(frames, ShotsConfig(min_shot_s=0.3)).cuts.size == 1
    assert detect_shots(frames, ShotsConfig(min_shot_s=0.5)).cuts.size == 0


def test_min_shot_s_is_measured_on_the_timestamps_not_in_frames(four_cameras) -> None:
    """The same 30-frame middle shot lasts 0.6 s or 0.3 s depending on the clock (a variable
    frame rate): only the longer one keeps the cut that ends it."""
    a, b, c, _ = four_cameras
    parts = [a, b[:30], c]
    rng = np.random.default_rng(0)
    jitter = rng.uniform(0.8, 1.2, 150)  # irregular frame intervals
    slow = (jitter * np.r_[[1 / 60] * 60, [1 / 50] * 30, [1 / 60] * 60]).tolist()
    fast = (jitter * np.r_[[1 / 60] * 60, [1 / 100] * 30, [1 / 60] * 60]).tolist()
    for dt, keeps_second in [(slow, True), (fast, False)]:
        frames = clocked(parts, dt)
        truth = first_times(parts, [t for t, _ in frames])
        shots = detect_shots(frames, ShotsConfig(min_shot_s=0.5))
        np.testing.assert_array_equal(shots.cuts, truth if keeps_second else truth[:1])
        np.testing.assert_array_equal(shots.timestamps, [t for t, _ in frames])


# -- the change signal and the detector modes -------------------------------------------------


def test_change_is_the_content_value_the_detector_thresholds(clips) -> None:
    """Against PySceneDetect's own public route: a StatsManager records `content_val`."""
    from scenedetect import FrameTimecode, StatsManager
    from scenedetect.detectors import ContentDetector

    frames = clips["cam04"][:30]
    shots = detect_shots(frames, ShotsConfig())
    reference, stats = ContentDetector(), StatsManager()
    reference.stats_manager = stats
    for i, (_, img) in enumerate(frames):
        reference.process_frame(FrameTimecode(i, fps=60.0), cv2.cvtColor(img, cv2.COLOR_RGB2BGR))
    expected = [
        stats.get_metrics(FrameTimecode(i, fps=60.0), ["content_val"])[0] for i in range(1, 30)
    ]
    assert np.isnan(shots.change[0])
    np.testing.assert_allclose(shots.change[1:], np.asarray(expected, np.float32), rtol=1e-6)


def test_detector_none_reports_no_cut_but_still_measures_change(clips) -> None:
    frames, _ = after(clips["cam01"], clips["cam03"])
    shots = detect_shots(frames, ShotsConfig(detector="none"))
    assert shots.cuts.size == 0
    assert shots.spans() == [(0, 200)]
    assert shots.change[100] > 27.0  # the cut is still visible in the change signal


def test_without_scenedetect_the_error_says_how_to_install_it(monkeypatch) -> None:
    for name in [m for m in sys.modules if m == "scenedetect" or m.startswith("scenedetect.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "scenedetect", None)  # import now fails
    with pytest.raises(DetectionError) as info:
        ShotDetector(ShotsConfig())
    message = str(info.value)
    assert INSTALL in message and "\n" not in message
    assert "pip install --no-deps scenedetect==0.7.2" in INSTALL


def test_frames_are_shrunk_to_a_longer_side_of_256_as_pyscenedetect_does() -> None:
    assert analysis_size(1920, 1080) == (256, 144)
    assert analysis_size(1080, 1920) == (144, 256)
    assert analysis_size(1768, 994) == (256, 144)
    assert analysis_size(202, 360) == (144, 256)
    assert analysis_size(200, 120) == (200, 120)


def test_a_frame_of_another_size_is_compared_at_the_same_analysis_size() -> None:
    detector = ShotDetector(ShotsConfig())
    detector.push(0.0, np.full((1920, 1080, 3), 100, np.uint8))
    detector.push(0.1, np.full((1000, 600, 3), 100, np.uint8))
    assert detector.result().change[1] == 0.0


def test_bad_input_is_refused() -> None:
    detector = ShotDetector(ShotsConfig())
    detector.push(1.0, np.zeros((8, 8, 3), np.uint8))
    with pytest.raises(ValueError, match="does not follow"):
        detector.push(1.0, np.zeros((8, 8, 3), np.uint8))
    with pytest.raises(ValueError, match="uint8"):
        detector.push(2.0, np.zeros((8, 8, 3), np.float32))
    with pytest.raises(ValueError, match="after the first"):
        Shots(np.array([0.0, 1.0]), np.array([0.5]), np.zeros(2))
    with pytest.raises(ValueError, match="after the first"):
        Shots(np.array([0.0, 1.0]), np.array([0.0]), np.zeros(2))


def test_no_frames_no_shots() -> None:
    shots = detect_shots([], ShotsConfig())
    assert shots.timestamps.size == shots.cuts.size == shots.change.size == 0
    assert shots.spans() == []


# -- the container ---------------------------------------------------------------------------


@given(
    st.lists(st.floats(0.001, 1.0), min_size=1, max_size=60),
    st.sets(st.integers(1, 59)),
)
def test_spans_cover_every_frame_exactly_once(steps, cut_indices) -> None:
    times = np.cumsum(steps)
    cuts = times[sorted(i for i in cut_indices if i < len(times))]
    shots = Shots(times, cuts, np.zeros(len(times), np.float32))
    spans = shots.spans()
    covered = [i for start, stop in spans for i in range(start, stop)]
    assert covered == list(range(len(times)))
    assert all(start < stop for start, stop in spans)
    assert [times[start] for start, _ in spans[1:]] == cuts.tolist()


def test_arrays_round_trip_through_npz_without_pickle() -> None:
    shots = Shots(
        np.array([0.0, 0.04, 0.1, 0.13]), np.array([0.1]), np.array([np.nan, 1.5, 40.0, 2.0])
    )
    buffer = io.BytesIO()
    np.savez(buffer, **shots.to_arrays())
    buffer.seek(0)
    with np.load(buffer, allow_pickle=False) as data:
        back = Shots.from_arrays(data)
    np.testing.assert_array_equal(back.timestamps, shots.timestamps)
    np.testing.assert_array_equal(back.cuts, shots.cuts)
    np.testing.assert_array_equal(back.change, shots.change)
    assert back.change.dtype == np.float32 and back.spans() == [(0, 2), (2, 4)]
