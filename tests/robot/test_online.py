"""Live mode: ONNX frame models, the per-frame pipeline, and real-time streaming of real speech."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from gesturebank.app.robot import load_frame_model
from gesturebank.audio.features import features
from gesturebank.audio.io import read_audio
from gesturebank.cli.robot import live_command
from gesturebank.config import AudioConfig
from gesturebank.errors import InputError
from gesturebank.robot import pepper
from gesturebank.robot.backends.record import read_record
from gesturebank.robot.online import LiveSynth
from gesturebank.testing.tiny_models import StepLSTM, write_model_dir
from gesturebank.train.model_folder import OnnxFrameModel
from tests.robot.test_playback import LOWER, NEUTRAL, UPPER, VELOCITY


@pytest.fixture(scope="module")
def speech(samples: Path) -> Path:
    return samples / "speech" / "arctic_a0007.wav"


@pytest.fixture(scope="module")
def speech_feats(speech: Path) -> np.ndarray:
    track = read_audio(speech, sample_rate=16000)
    assert track is not None
    return features(track.signal, 16000, config=AudioConfig())


@pytest.mark.parametrize("kind", ["lstm", "mlp"])
def test_onnx_step_matches_torch(tmp_path: Path, kind: str) -> None:
    folder = write_model_dir(tmp_path / kind, kind=kind, hidden=8)
    model = OnnxFrameModel(folder / ("model_step.onnx" if kind == "lstm" else "model.onnx"))
    x = np.random.default_rng(1).normal(size=(5, 26)).astype(np.float32)
    ours = np.stack([model.step(row) for row in x])
    torch.manual_seed(0)  # the same weights as write_model_dir's
    if kind == "lstm":
        ref = StepLSTM(26, 8).eval()
        with torch.no_grad():
            out, _ = ref.lstm(torch.from_numpy(x)[None])  # the whole sequence in one go
            expected = torch.sigmoid(ref.head(out[0])).numpy()
    else:
        from gesturebank.testing.tiny_models import MLP

        with torch.no_grad():
            expected = MLP(26, 8).eval()(torch.from_numpy(x)).numpy()
    np.testing.assert_allclose(ours, expected, atol=1e-5)
    model.reset()
    np.testing.assert_allclose(model.step(x[0]), expected[0], atol=1e-5)


def test_load_frame_model_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="model.onnx: missing"):
        load_frame_model(tmp_path)
    folder = write_model_dir(tmp_path / "m", n_features=26)
    with pytest.raises(InputError, match="no audio statistics for 'anna'"):
        load_frame_model(folder, znorm="anna")
    norm = json.loads((folder / "normalisers.json").read_text())
    norm["audio_znorm_by_subject"]["*"] = {"mean": [0.0] * 13, "std": [1.0] * 13}
    (folder / "normalisers.json").write_text(json.dumps(norm))
    with pytest.raises(InputError, match="takes 26 features, normalisers have 13"):
        load_frame_model(folder)


def test_pipeline_is_safe_and_follows_speech(
    tmp_path: Path, speech: Path, speech_feats: np.ndarray
) -> None:
    model = load_frame_model(write_model_dir(tmp_path / "m", feats=speech_feats))
    synth = LiveSynth(model)
    track = read_audio(speech, sample_rate=16000)
    assert track is not None
    hop = 160
    poses = np.stack(
        [synth.push(track.signal[k * hop : (k + 1) * hop]) for k in range(len(track.signal) // hop)]
    )
    assert np.all(poses >= LOWER - 1e-6) and np.all(poses <= UPPER + 1e-6)
    speed = np.abs(np.diff(np.vstack([NEUTRAL, poses]), axis=0)) / 0.01
    assert np.all(speed <= VELOCITY * (1 + 1e-4) + 1e-4)
    assert np.ptp(poses, axis=0).max() > 0.05  # speech moves the robot


def test_live_wav_in_real_time(tmp_path: Path, speech: Path, speech_feats: np.ndarray) -> None:
    folder = write_model_dir(tmp_path / "m", feats=speech_feats)
    out = tmp_path / "live.jsonl"
    result = live_command(folder, backend="record", input=str(speech), out=out)
    track = read_audio(speech, sample_rate=16000)
    assert track is not None
    n_chunks = len(track.signal) // 160
    live = [c for c in read_record(out) if c["phase"] == "live"]
    assert result.n_sent == n_chunks == len(live) and result.skipped == 0
    sent = np.array([c["t"] for c in live])
    assert np.all(np.diff(sent) > 0)  # in order
    # real time: the frames cannot come faster than the audio (a busy machine makes them later)
    assert sent[-1] - sent[0] >= 0.01 * (n_chunks - 1) - 0.02
    p50, p99 = result.latency_ms()  # printed; benchmarks/live.py measures it
    print(f"\nlive (record backend, {n_chunks} frames): latency p50 {p50:.2f} ms, p99 {p99:.2f} ms")
    angles = np.array([c["angles"] for c in read_record(out)])
    assert np.all(angles >= LOWER - 1e-6) and np.all(angles <= UPPER + 1e-6)


def test_missing_microphone_is_one_line(tmp_path: Path) -> None:
    folder = write_model_dir(tmp_path / "m")
    with pytest.raises(InputError) as info:
        live_command(
            folder, backend="record", input="mic", out=tmp_path / "x.jsonl", max_seconds=0.5
        )
    msg = str(info.value)
    assert msg.startswith("microphone:") and "\n" not in msg
    assert not (tmp_path / "x.jsonl").exists()  # failed before touching the robot


def test_missing_portaudio_names_the_package(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a stand-in that fails as sounddevice does on a machine without PortAudio
    (tmp_path / "sounddevice.py").write_text("raise OSError('PortAudio library not found')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "sounddevice", raising=False)
    folder = write_model_dir(tmp_path / "m")
    with pytest.raises(InputError) as info:
        live_command(
            folder, backend="record", input="mic", out=tmp_path / "x.jsonl", max_seconds=0.5
        )
    msg = str(info.value)
    assert "PortAudio library not found" in msg and "apt-get install libportaudio2" in msg
    assert "\n" not in msg


@pytest.mark.parametrize("kind", ["mlp", "lstm"])
def test_live_runs_a_model_trained_by_gesturebank(
    demo_dataset: Path, tmp_path: Path, speech: Path, kind: str
) -> None:
    """The model folder `gesturebank train` writes is what live mode loads, as it is."""
    from gesturebank.cli.training import train_command
    from gesturebank.config import TrainConfig

    cfg = TrainConfig.model_validate({"mlp": {"max_epochs": 3}, "lstm": {"max_epochs": 2}})
    folder = tmp_path / kind
    train_command(
        demo_dataset,
        model=kind,
        variant="sd",
        subject="lab",
        out_dir=folder,
        config=cfg,
        quiet=True,
    )
    model = load_frame_model(folder, znorm="lab")
    synth = LiveSynth(model)
    track = read_audio(speech, sample_rate=16000)
    assert track is not None
    poses = np.stack([synth.push(track.signal[k : k + 160]) for k in range(0, 16000, 160)])
    profile = pepper.load_profile(model.profile)
    assert poses.shape == (100, 11)
    assert np.isfinite(poses).all()
    assert np.all(poses >= profile.lower) and np.all(poses <= profile.upper)
