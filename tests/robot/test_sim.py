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

from gesturebank.cli.robot import replay_command
from gesturebank.config import PlaybackConfig, RenderConfig
from gesturebank.errors import InputError
from gesturebank.robot import pepper
from gesturebank.robot.backends import BACKENDS, Command
from gesturebank.robot.backends.sim import SimBackend
from gesturebank.robot.timeline import Timeline, write_timeline

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
    csv = write_timeline(tmp_path / "a.csv", five_seconds(POSE))
    out = tmp_path / "sim.mp4"
    render = RenderConfig(frame_rate=25, width_px=320, height_px=240, ramps=False)
    wav = tone_wav(tmp_path / "a.wav", 5.0)
    replay_command(csv, backend="sim", out=out, audio=wav, config=PlaybackConfig(), render=render)
    frames, duration, fps, samples = decode(out)
    assert len(frames) == 125 and fps == 25
    assert duration == pytest.approx(5.0, abs=0.05)
    assert samples == pytest.approx(5.0 * RATE, abs=2048)  # AAC pads up to one frame
    frame = frames[62]
    assert frame.shape == (240, 320, 3)
    av.VideoFrame.from_ndarray(frame, format="rgb24").to_image().save(artifacts / "sim_frame.png")


def test_sim_shows_the_safety_moves_with_the_audio_delayed(tmp_path: Path) -> None:
    # Start move (≥ start_s) + lead + 5 s + return (≥ return_s): the video covers all of it, and
    # the audio starts where the timeline does, so it ends before the video.
    csv = write_timeline(tmp_path / "a.csv", five_seconds(POSE))
    out = tmp_path / "ramps.mp4"
    render = RenderConfig(frame_rate=25, width_px=160, height_px=120)
    cfg = PlaybackConfig(start_s=1.0, return_s=1.0)
    wav = tone_wav(tmp_path / "a.wav", 5.0)
    replay_command(csv, backend="sim", out=out, audio=wav, config=cfg, render=render)
    frames, duration, _, samples = decode(out)
    assert duration >= 5.0 + 1.0 + 1.0 + cfg.lead_s - 0.05
    assert len(frames) == pytest.approx(duration * 25, abs=1)
    with av.open(str(out)) as c:
        sound = np.concatenate([f.to_ndarray()[0] for f in c.decode(audio=0)])
    onset = int(np.argmax(np.abs(sound) > 0.05)) / RATE  # silence during the start move
    assert onset >= 1.0 + cfg.lead_s - 0.03
    assert samples == pytest.approx((onset + 5.0) * RATE, abs=2048)
    # the first frame (neutral, arms hanging) differs from one in the timeline (left arm up)
    assert np.mean(np.abs(frames[0].astype(int) - frames[len(frames) // 2].astype(int))) > 0.5


def test_sim_side_by_side(tmp_path: Path) -> None:
    a = write_timeline(tmp_path / "pred.csv", five_seconds(POSE))
    b = write_timeline(
        tmp_path / "truth.csv", five_seconds(POSE[[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10]])
    )
    render = RenderConfig(width_px=200, height_px=150, ramps=False)
    out = replay_command(a, backend="sim", out=tmp_path / "sbs.mp4", compare=[b], render=render)
    assert isinstance(out, Path)
    frames, _, _, samples = decode(out)
    assert frames[0].shape == (150, 400, 3) and len(frames) == 125 and samples == 0
    # Same poses on both sides → the two halves look the same but for their labels (top rows).
    diff = np.abs(frames[60][40:, :200].astype(int) - frames[60][40:, 200:].astype(int))
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
    csv = write_timeline(tmp_path / "a.csv", neutral(0.5))
    (tmp_path / "afile").write_text("not a folder")
    out = tmp_path / "afile" / "v.mp4" if where == "under_a_file" else tmp_path / "v.mp4"
    if where == "is_a_folder":
        out.mkdir()
    cfg = PlaybackConfig(start_s=0.1, return_s=0.1)
    render = RenderConfig(width_px=160, height_px=120)
    with pytest.raises(InputError) as info:
        replay_command(csv, backend="sim", out=out, config=cfg, render=render)
    msg = str(info.value)
    assert msg.startswith(f"{out}: cannot write video") and "\n" not in msg
    assert [p.name for p in tmp_path.rglob(".*")] == []  # no temporary file left behind
    assert (tmp_path / "afile").read_text() == "not a folder"


def test_cli_sim_unwritable_output_exit_2(tmp_path: Path) -> None:
    csv = write_timeline(tmp_path / "a.csv", neutral(0.5))
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
    csv = write_timeline(tmp_path / "a.csv", neutral(2.0))
    out = tmp_path / "out" / "v.mp4"
    result = replay_command(csv, backend="sim", out=out, config=PlaybackConfig(start_s=0.1))
    assert not isinstance(result, Path) and result.status == "interrupted"
    assert not out.parent.exists() or not any(out.parent.iterdir())


def test_ctrl_c_during_sim_render_leaves_nothing(tmp_path: Path) -> None:
    # 10 minutes of timeline: the render takes long enough to be interrupted while it writes.
    csv = write_timeline(tmp_path / "long.csv", neutral(600.0, rate_hz=10.0))
    folder = tmp_path / "out"
    folder.mkdir()
    cmd = [str(BIN / "gesturebank"), "replay", str(csv), "--backend", "sim"]
    cmd += ["--out", str(folder / "v.mp4"), "--set", "render.height_px=120"]
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


def test_old_sim_keys_still_load(tmp_path: Path) -> None:
    # datasets and config files written before [render] carry playback.sim_fps / sim_view_px
    from gesturebank.config import Config, load_config

    path = tmp_path / "old.toml"
    path.write_text("[playback]\nsim_fps = 30\nsim_view_px = 200\n")
    assert load_config(path).render.frame_rate == 30
    old = Config().to_json_dict()
    old["playback"] |= {"sim_fps": 12, "sim_view_px": 360}
    del old["render"]
    assert Config.model_validate(old).render == RenderConfig(frame_rate=12)
