"""The `sim` backend: a real MP4 with audio, decoded back; one frame saved for a person to see."""

from __future__ import annotations

import wave
from pathlib import Path

import av
import numpy as np
import pytest

from gesturebank.robot.playback import PlaybackConfig, replay_command
from gesturebank.robot.timeline import Timeline, write_csv

RATE = 16000
# Left arm raised sideways (LShoulderRoll 1.3), right arm hanging; Table 3.1 conventions.
POSE = np.array([0.0, 0.0, 1.3, 0.2, -0.3, 0.0, -0.05, 1.5, 0.3, 0.0, 0.0])


def tone_wav(path: Path, seconds: float) -> Path:
    t = np.arange(int(seconds * RATE)) / RATE
    x = (0.3 * np.sin(2 * np.pi * 440 * t) * 32767).astype(np.int16)
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(RATE)
        w.writeframes(x.tobytes())
    return path


def five_seconds(pose: np.ndarray) -> Timeline:
    n = 500
    times = np.arange(n) * 0.01
    angles = np.tile(pose, (n, 1))
    angles[:, 1] = 0.4 * np.sin(2 * np.pi * times / 5)  # the head turns a little
    return Timeline.of(times, angles)


def decode(path: Path) -> tuple[list[np.ndarray], float, float, int]:
    with av.open(str(path)) as c:
        frames = [f.to_ndarray(format="rgb24") for f in c.decode(video=0)]
    with av.open(str(path)) as c:
        v, a = c.streams.video[0], c.streams.audio
        samples = sum(f.samples for f in c.decode(audio=0)) if a else 0
        fps = float(v.average_rate)
        return frames, float(c.duration or 0) / 1e6, fps, samples


def test_sim_renders_5s_with_audio(tmp_path: Path, artifacts: Path) -> None:
    csv = write_csv(tmp_path / "a.csv", five_seconds(POSE))
    out = tmp_path / "sim.mp4"
    cfg = PlaybackConfig(sim_fps=25, sim_view_px=360)
    replay_command(csv, "sim", out=out, audio=tone_wav(tmp_path / "a.wav", 5.0), config=cfg)
    frames, duration, fps, samples = decode(out)
    assert len(frames) == 125 and fps == 25
    assert duration == pytest.approx(5.0, abs=0.05)
    assert samples == pytest.approx(5.0 * RATE, abs=2048)  # AAC pads up to one frame
    frame = frames[62]
    assert frame.shape == (360, 720, 3)
    av.VideoFrame.from_ndarray(frame, format="rgb24").to_image().save(artifacts / "sim_frame.png")
    # Front view (left half): the raised left arm is drawn in blue on the viewer's right, high up
    # (above the mid-height of the view); the right arm is red, lower, on the viewer's left.
    front = frame[:, :360].astype(int)
    blue = (front[..., 2] > 150) & (front[..., 0] < 100)
    red = (front[..., 0] > 150) & (front[..., 2] < 100)
    by, bx = np.nonzero(blue)
    ry, rx = np.nonzero(red)
    assert len(bx) > 50 and len(rx) > 50
    assert bx.mean() > 180 > rx.mean()
    assert by.mean() < ry.mean()


def test_sim_side_by_side(tmp_path: Path) -> None:
    a = write_csv(tmp_path / "pred.csv", five_seconds(POSE))
    b = write_csv(tmp_path / "truth.csv", five_seconds(POSE[[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10]]))
    cfg = PlaybackConfig(sim_view_px=200)
    out = replay_command(a, "sim", out=tmp_path / "sbs.mp4", compare=b, config=cfg)
    assert isinstance(out, Path)
    frames, _, _, samples = decode(out)
    assert frames[0].shape == (200, 800, 3) and len(frames) == 125 and samples == 0
    # Same poses on both sides → the two halves look the same.
    diff = np.abs(frames[60][:, :400].astype(int) - frames[60][:, 400:].astype(int))
    assert np.mean(diff) < 3
