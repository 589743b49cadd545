"""Camera synchronisation on real media: speech audio (re-encoded, shifted copies) and the
keypoint motion of the Pose2Sim demo's synchronised cameras."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import av
import numpy as np
import pytest

from gesturebank.app.extract import extract_take
from gesturebank.audio.io import Audio, read_audio
from gesturebank.config import Config
from gesturebank.errors import InputError
from gesturebank.lift.multiview.sync import (
    align,
    audio_offset,
    estimate_offsets,
    motion_offset,
    signal_lag,
)
from gesturebank.poses import Pose2D

TALKING = "talking/lab/cam01_arctic.mp4"
FULL_RATE = Config.model_validate({"video": {"max_fps": None}})  # the demo's 60 fps frames
SR = 16000
FPS = 60


def write_late_copy(src: Path, dst: Path, drop_frames: int) -> None:
    """A copy of `src` as a camera would have filmed it had it started `drop_frames` video
    frames later: video from that frame on, audio from the same instant, both re-encoded
    (H.264 at quarter size, AAC 16 kHz mono), timestamps starting at 0."""
    audio = read_audio(src, sample_rate=SR)
    assert audio is not None and audio.start_offset_s == 0.0
    with av.open(str(src)) as inp, av.open(str(dst), "w") as out:
        vin = inp.streams.video[0]
        vout = out.add_stream("libx264", rate=FPS)
        vout.width, vout.height, vout.pix_fmt = 270, 480, "yuv420p"
        vout.codec_context.time_base = Fraction(1, FPS)
        aout = out.add_stream("aac", rate=SR, layout="mono")
        for i, frame in enumerate(inp.decode(vin)):
            if i < drop_frames:
                continue
            small = frame.reformat(width=270, height=480, format="yuv420p")
            small.pts, small.time_base = i - drop_frames, Fraction(1, FPS)
            out.mux(vout.encode(small))
        out.mux(vout.encode())
        signal = audio.signal[drop_frames * SR // FPS :]
        for start in range(0, signal.size, 1024):
            chunk = np.ascontiguousarray(signal[None, start : start + 1024], np.float32)
            aframe = av.AudioFrame.from_ndarray(chunk, format="fltp", layout="mono")
            aframe.sample_rate, aframe.pts, aframe.time_base = SR, start, Fraction(1, SR)
            out.mux(aout.encode(aframe))
        out.mux(aout.encode())


@pytest.mark.parametrize("drop_frames", [6, 21])
def test_audio_realigns_a_late_camera(samples: Path, tmp_path: Path, drop_frames: int) -> None:
    src = samples / TALKING
    late = tmp_path / "late.mp4"
    write_late_copy(src, late, drop_frames)
    a_ref, a_late = read_audio(src, sample_rate=SR), read_audio(late, sample_rate=SR)
    assert a_ref is not None and a_late is not None
    lag = audio_offset(a_ref, a_late, max_lag_s=1.0)
    expected = -drop_frames / FPS  # the late camera's clock is behind by that much
    print(f"\ndropped {drop_frames} frames: offset {lag.seconds:+.4f} s "
          f"(expected {expected:+.4f}), score {lag.score:.2f}")  # fmt: skip
    assert lag.seconds == pytest.approx(expected, abs=1 / FPS)
    assert lag.score > 0.5
    # Against itself (swapped roles) the offset flips sign.
    assert audio_offset(a_late, a_ref, max_lag_s=1.0).seconds == pytest.approx(
        -lag.seconds, abs=1e-3
    )


@pytest.mark.parametrize("shift", [1234, -777, 0])
def test_shifted_speech_samples_realign_exactly(samples: Path, shift: int) -> None:
    speech = read_audio(samples / "speech/arctic_a0007.wav", sample_rate=SR)
    assert speech is not None
    x = speech.signal
    # `other` hears the same sound `shift` samples later (earlier if negative).
    other = np.concatenate([np.zeros(shift, np.float32), x]) if shift >= 0 else x[-shift:]
    lag = signal_lag(x, other, rate=SR, max_lag_s=0.5)
    assert round(lag.seconds * SR) == shift
    assert lag.score > 0.99


def test_audio_start_offsets_are_accounted_for(samples: Path) -> None:
    """The same track, but the container says audio starts 0.25 s after the first frame."""
    speech = read_audio(samples / "speech/arctic_a0007.wav", sample_rate=SR)
    assert speech is not None
    late = Audio(speech.signal, SR, 0.25)
    assert audio_offset(speech, late).seconds == pytest.approx(0.25, abs=1 / SR)
    assert audio_offset(speech, late, other_start_s=1.0).seconds == pytest.approx(1.25, abs=1e-3)


def test_no_correlation_on_silence_scores_low() -> None:
    rng = np.random.default_rng(0)
    lag = signal_lag(rng.normal(size=8000), rng.normal(size=8000), rate=SR, max_lag_s=0.2)
    assert lag.score < 0.2
    with pytest.raises(InputError, match="sample rates differ"):
        audio_offset(Audio(np.zeros(10), 16000, 0.0), Audio(np.zeros(10), 8000, 0.0))


@pytest.fixture(scope="module")
def demo_poses(samples: Path) -> list[Pose2D]:
    """Detections of the 4 synchronised demo cameras (cached on disk after the first run)."""
    videos = samples / "pose2sim/Demo_SinglePerson/videos"
    return [
        extract_take(videos / f"cam0{i}.mp4", FULL_RATE, with_audio=False).tracked.pose
        for i in range(1, 5)
    ]


def late_pose(pose: Pose2D, drop_frames: int) -> Pose2D:
    """The same view as seen by a camera that started `drop_frames` frames later."""
    kp = pose.keypoints[drop_frames:]
    ts = pose.timestamps[drop_frames:] - pose.timestamps[drop_frames]
    return Pose2D(kp, ts, pose.skeleton, pose.image_size)


@pytest.mark.parametrize("drop_frames", [9, 25])
def test_motion_realigns_a_late_copy(demo_poses: list[Pose2D], drop_frames: int) -> None:
    """The same view's keypoints, as recorded by a camera started `drop_frames` later."""
    ref = demo_poses[0]
    offsets, methods, _ = estimate_offsets(
        [ref, late_pose(ref, drop_frames)], method="motion", max_lag_s=0.8
    )
    assert methods == ["reference", "motion"]
    assert offsets[1] == pytest.approx(-drop_frames / FPS, abs=1 / FPS)


# Across different views, 2D motion differs with the viewpoint: on this 1.7 s clip the motion
# estimate is within a few frames, not exact (measured with blazepose: 1–4.5 frames; with
# mediapipe's solution 2.5–3). Audio is the precise cue.
CROSS_VIEW_TOLERANCE_S = 5 / FPS


def test_motion_across_views_of_synchronised_cameras(demo_poses: list[Pose2D]) -> None:
    ref = demo_poses[0]
    for c, other in enumerate(demo_poses[1:], start=1):
        lag = motion_offset(ref, other, max_lag_s=0.5)
        print(f"\ncam0{c + 1} vs cam01: motion offset {lag.seconds * FPS:+.2f} frames, "
              f"score {lag.score:.2f}")  # fmt: skip
        assert abs(lag.seconds) <= CROSS_VIEW_TOLERANCE_S


@pytest.mark.parametrize("drop_frames", [9, 25])
def test_motion_realigns_another_late_view(demo_poses: list[Pose2D], drop_frames: int) -> None:
    late = late_pose(demo_poses[3], drop_frames)
    offsets, _, _ = estimate_offsets([demo_poses[0], late], method="motion", max_lag_s=0.8)
    assert offsets[1] == pytest.approx(-drop_frames / FPS, abs=CROSS_VIEW_TOLERANCE_S)


def test_auto_prefers_audio_and_falls_back_to_motion(
    samples: Path, demo_poses: list[Pose2D]
) -> None:
    speech = read_audio(samples / TALKING, sample_rate=SR)
    assert speech is not None
    poses = [demo_poses[0], demo_poses[1], demo_poses[2]]
    shifted = Audio(speech.signal, SR, 0.05)
    offsets, methods, _ = estimate_offsets(poses, [speech, shifted, None], method="auto")
    assert methods == ["reference", "audio", "motion"]
    assert offsets[1] == pytest.approx(0.05, abs=1e-3)
    assert abs(offsets[2]) <= CROSS_VIEW_TOLERANCE_S
    with pytest.raises(InputError, match="audio sync asked for"):
        estimate_offsets(poses, [speech, shifted, None], method="audio")


def test_align_interpolates_on_the_reference_clock() -> None:
    T = 30
    ts = np.arange(T) / 30.0
    x = np.linspace(0, 290, T, dtype=np.float32)  # a keypoint moving at constant speed
    kp = np.zeros((T, 17, 3), np.float32)
    kp[..., 0], kp[..., 1], kp[..., 2] = x[:, None], 5.0, 0.9
    kp[10, 3] = np.nan  # one missing observation
    pose = Pose2D(kp, ts, "coco17", (640, 480))
    times = np.arange(40) / 30.0
    out = align([pose, pose], [0.0, 0.05], times=times)  # view 1's clock runs 50 ms ahead
    np.testing.assert_allclose(out[0, :T, 0, 0], x, atol=1e-4)
    assert np.isnan(out[0, T:]).all()  # after the last frame
    # View 1 at reference time t shows its frame stamped t + 0.05 s: x + 0.05 s × speed.
    speed = 290 / ((T - 1) / 30.0)
    valid = times + 0.05 <= ts[-1]
    np.testing.assert_allclose(out[1, valid, 0, 0], x[: valid.sum()] + 0.05 * speed, atol=1e-3)
    assert np.isnan(out[1, ~valid]).all()
    assert np.isnan(out[0, 10, 3]).all() and np.isnan(out[1, 8:10, 3]).all()
    np.testing.assert_allclose(out[1, 12, 3, 2], 0.9)
