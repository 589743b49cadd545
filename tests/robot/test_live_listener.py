"""`live --role listener` (seed 004): the robot listens — a listener model trained by
gesturebank turns the speech on the input and whether the person speaks (streamed Silero VAD)
into head motion; only the head moves, within the same limits; a model of the other role is
refused in one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturebank.app.robot import load_frame_model
from gesturebank.audio.io import read_audio
from gesturebank.audio.vad import CHUNK, chunk_probabilities
from gesturebank.audio.vad_stream import StreamingSpeech
from gesturebank.cli.robot import live_command
from gesturebank.config import PlaybackConfig, SpeechConfig, TrainConfig
from gesturebank.errors import InputError
from gesturebank.robot import pepper
from gesturebank.robot.backends.record import read_record
from gesturebank.robot.safety import safe_pose, speed_profile
from gesturebank.testing.tiny_models import write_model_dir

HEAD = np.isin(np.array(pepper.JOINTS), pepper.HEAD_JOINTS)


@pytest.fixture(scope="module")
def speech(samples: Path) -> Path:
    return samples / "speech" / "arctic_a0007.wav"


@pytest.fixture(scope="module")
def listener_model(dyad_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A causal listener model (LSTM) trained by `train --target listener` on two people."""
    from gesturebank.cli.training import train_command

    cfg = TrainConfig.model_validate(
        {"target": "listener", "lstm": {"max_epochs": 2, "seq_len": 100}}
    )
    out = tmp_path_factory.mktemp("listener") / "model"
    train_command(dyad_dataset, model="lstm", variant="dyadic", out_dir=out, config=cfg, quiet=True)
    return out


def test_streamed_speech_detection_is_the_offline_one(speech: Path) -> None:
    """Pushed 10 ms at a time, the streaming detector gives the offline detector's probability
    for every 32 ms chunk (same model, state and context), and its flag is their hysteresis."""
    track = read_audio(speech, sample_rate=16000)
    assert track is not None
    offline = chunk_probabilities(track.signal)
    stream = StreamingSpeech(sample_rate=16000, config=SpeechConfig())
    probabilities, flags = [], []
    for k in range(0, len(track.signal) - 159, 160):
        before = stream.probability
        flag = stream.push(track.signal[k : k + 160])
        if (k + 160) // CHUNK > k // CHUNK:  # a chunk was completed by this push
            probabilities.append(stream.probability)
            flags.append(flag)
        else:
            assert stream.probability == before
    n = len(probabilities)
    assert n == len(track.signal) // CHUNK
    np.testing.assert_allclose(probabilities, offline[:n], atol=1e-5)
    assert any(flags) and not all(flags)  # an utterance with silence around it
    with pytest.raises(InputError, match="needs 16000 Hz audio"):
        StreamingSpeech(sample_rate=8000, config=SpeechConfig())


def test_live_listener_moves_only_the_head_within_the_limits(
    listener_model: Path, speech: Path, tmp_path: Path
) -> None:
    out = tmp_path / "live.jsonl"
    cfg = PlaybackConfig()
    result = live_command(
        listener_model, backend="record", input=str(speech), out=out, role="listener"
    )
    assert result.status == "completed" and result.skipped == 0
    live = [c for c in read_record(out) if c["phase"] == "live"]
    assert len(live) == result.n_sent > 100
    angles = np.array([c["angles"] for c in live])
    profile = speed_profile(load_frame_model(listener_model).robot, cfg.max_speed_fraction)
    assert np.all(angles >= profile.lower - 1e-6) and np.all(angles <= profile.upper + 1e-6)
    step = np.abs(np.diff(angles, axis=0)) / 0.01
    assert np.all(step <= np.asarray(profile.velocity) * (1 + 1e-4) + 1e-4)
    # the arms and the hip hold the (safe) neutral pose; the head moves with the speech
    neutral = safe_pose(pepper.neutral_pose(), profile)
    assert np.ptp(angles[:, ~HEAD], axis=0).max() == 0.0  # not a step, to the written digit
    np.testing.assert_allclose(angles[0, ~HEAD], neutral[~HEAD], atol=1e-6)  # 6 digits written
    assert np.ptp(angles[:, HEAD], axis=0).max() > 1e-3


def test_live_refuses_a_model_of_the_other_role(
    listener_model: Path, speech: Path, tmp_path: Path
) -> None:
    speaker = write_model_dir(tmp_path / "speaker")  # a speaker model (no target: speaker)
    with pytest.raises(InputError) as info:
        live_command(
            speaker, backend="record", input=str(speech), out=tmp_path / "a.jsonl", role="listener"
        )
    message = str(info.value)
    assert "a speaker model cannot play --role listener" in message
    assert "--target listener" in message and "\n" not in message
    with pytest.raises(InputError, match="a listener model cannot play --role speaker"):
        live_command(
            listener_model,
            backend="record",
            input=str(speech),
            out=tmp_path / "b.jsonl",
            role="speaker",
        )
    assert not (tmp_path / "a.jsonl").exists() and not (tmp_path / "b.jsonl").exists()


def test_live_listener_over_qi_moves_only_the_head(
    listener_model: Path, speech: Path, tmp_path: Path
) -> None:
    """Over a real qi session (a recording ALMotion in a subprocess): once the start move has
    brought the robot to neutral, every command keeps the arms and hip there; only the head
    moves, within the limits."""
    from gesturebank.testing.naoqi_server import NaoqiServer

    robot = load_frame_model(listener_model).robot
    arms_up = np.clip(pepper.neutral_pose() + np.where(HEAD, 0.0, 0.3), robot.lower, robot.upper)
    cfg = PlaybackConfig(start_s=0.3, return_s=0.3)
    with NaoqiServer(dict(zip(pepper.JOINTS, arms_up.tolist(), strict=True)), lifetime_s=60) as srv:
        result = live_command(
            listener_model,
            backend="naoqi",
            input=str(speech),
            url=srv.url,
            config=cfg,
            role="listener",
        )
        sets = [c for c in srv.calls() if c["call"] == "setAngles"]
    order = [sets[0]["names"].index(j) for j in pepper.JOINTS]
    angles = np.array([c["angles"] for c in sets])[:, order]
    profile = speed_profile(robot, cfg.max_speed_fraction)
    assert np.all(angles >= profile.lower - 1e-6) and np.all(angles <= profile.upper + 1e-6)
    neutral = safe_pose(pepper.neutral_pose(), profile)
    settled = np.all(np.abs(angles[:, ~HEAD] - neutral[~HEAD]) < 1e-5, axis=1)
    first = int(np.argmax(settled))
    assert first > 0 and settled[first:].all()  # the arms came down once and stayed
    assert len(angles) - first >= result.n_sent
    assert np.ptp(angles[first:, HEAD], axis=0).max() > 1e-3


def test_live_help_names_the_roles() -> None:
    from typer.testing import CliRunner

    from gesturebank.cli import app

    result = CliRunner().invoke(app, ["live", "--help"], terminal_width=200)
    assert result.exit_code == 0
    text = " ".join(result.output.replace("│", " ").split())
    assert "--role <speaker|listener>" in text and "listens and nods" in text


def test_synthesize_with_a_listener_model_moves_only_the_head(
    listener_model: Path, speech: Path, tmp_path: Path
) -> None:
    """Offline, a listener model gets the file's speaking flag (the VAD) and its timeline moves
    the head only; the flag matters: another flag gives another head motion."""
    from gesturebank.train.synthesis import synthesize

    heard = synthesize(listener_model, audio_path=speech, out_csv=tmp_path / "a.csv")
    never = SpeechConfig(threshold=0.999, release_threshold=0.999)  # hears (almost) no speech
    deaf = synthesize(listener_model, audio_path=speech, out_csv=tmp_path / "b.csv", speech=never)
    robot = load_frame_model(listener_model).robot
    rest = pepper.clamp(pepper.neutral_pose().reshape(1, -1), robot)[0]
    for angles in (heard, deaf):
        assert np.isfinite(angles).all()
        np.testing.assert_array_equal(angles[:, ~HEAD], np.tile(rest[~HEAD], (len(angles), 1)))
    assert np.abs(heard[:, HEAD] - deaf[:, HEAD]).max() > 1e-4
