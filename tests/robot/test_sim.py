"""The `sim` backend: a real MP4 with audio, decoded back; one frame saved for a person to see."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
import wave
from pathlib import Path

import av
import numpy as np
import pytest

from gesturebank.config import PlaybackConfig
from gesturebank.errors import InputError
from gesturebank.robot import pepper
from gesturebank.robot.backends import BACKENDS, Command
from gesturebank.robot.backends.sim import SimBackend
from gesturebank.robot.commands import replay_command
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


# --------------------------------------------------------------------------------------------------
# Outputs: one line when unwritable, nothing under the final name when interrupted (issue #16)

BIN = Path(sys.executable).parent


def neutral(seconds: float, rate_hz: float = 100.0) -> Timeline:
    n = round(seconds * rate_hz)
    times = np.arange(n) / rate_hz
    angles = np.tile(pepper.neutral_pose(), (n, 1))
    angles[:, 1] = 0.4 * np.sin(2 * np.pi * times / 5)
    return Timeline.of(times, angles)


@pytest.mark.parametrize("where", ["under_a_file", "is_a_folder"])
def test_sim_unwritable_output_is_one_line_naming_it(tmp_path: Path, where: str) -> None:
    csv = write_csv(tmp_path / "a.csv", neutral(0.5))
    (tmp_path / "afile").write_text("not a folder")
    out = tmp_path / "afile" / "v.mp4" if where == "under_a_file" else tmp_path / "v.mp4"
    if where == "is_a_folder":
        out.mkdir()
    cfg = PlaybackConfig(start_s=0.1, return_s=0.1, sim_view_px=120)
    with pytest.raises(InputError) as info:
        replay_command(csv, "sim", out=out, config=cfg)
    msg = str(info.value)
    assert msg.startswith(f"{out}: cannot write video") and "\n" not in msg
    assert [p.name for p in tmp_path.rglob(".*")] == []  # no temporary file left behind
    assert (tmp_path / "afile").read_text() == "not a folder"


def test_cli_sim_unwritable_output_exit_2(tmp_path: Path) -> None:
    csv = write_csv(tmp_path / "a.csv", neutral(0.5))
    (tmp_path / "afile").write_text("not a folder")
    out = tmp_path / "afile" / "v.mp4"
    cmd = [str(BIN / "gesturebank"), "replay", str(csv), "--backend", "sim", "--out", str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {out}: cannot write video"), r.stderr


class InterruptedSim(SimBackend):
    """The real sim backend, whose user presses Ctrl-C at timeline frame 50 of the playback."""

    def send(self, cmd: Command) -> None:
        if cmd.phase == "timeline" and sum(c.phase == "timeline" for c in self.commands) == 50:
            raise KeyboardInterrupt
        super().send(cmd)


def test_interrupted_sim_replay_writes_no_video(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(BACKENDS._factories, "sim", lambda *, out, **_: InterruptedSim(out))
    csv = write_csv(tmp_path / "a.csv", neutral(2.0))
    out = tmp_path / "out" / "v.mp4"
    result = replay_command(csv, "sim", out=out, config=PlaybackConfig(start_s=0.1))
    assert not isinstance(result, Path) and result.status == "interrupted"
    assert not out.parent.exists() or not any(out.parent.iterdir())


def test_ctrl_c_during_sim_render_leaves_nothing(tmp_path: Path) -> None:
    # 10 minutes of timeline: the render takes long enough to be interrupted while it writes.
    csv = write_csv(tmp_path / "long.csv", neutral(600.0, rate_hz=10.0))
    folder = tmp_path / "out"
    folder.mkdir()
    cmd = [str(BIN / "gesturebank"), "replay", str(csv), "--backend", "sim"]
    cmd += ["--out", str(folder / "v.mp4"), "--set", "playback.sim_view_px=120"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for _ in range(6000):  # until the video is being written (a 10 min bound, not a timing)
            if proc.poll() is not None or any(folder.iterdir()):
                break
            time.sleep(0.1)
        assert proc.poll() is None, "the render ended before it could be interrupted"
        assert any(folder.iterdir()), "no output appeared"
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert list(folder.iterdir()) == []  # no truncated video, no temporary file
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr and "interrupted" in stdout
