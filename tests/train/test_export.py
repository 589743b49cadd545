"""ONNX graphs equal the PyTorch models; the stateful step LSTM equals the full-sequence one."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from gesturebank.errors import InputError
from gesturebank.train.export import OnnxModel, StreamingLSTM, export_onnx
from gesturebank.train.model_folder import MODEL_ONNX, STEP_ONNX
from gesturebank.train.models.dissertation import MLP, LSTMModel
from gesturebank.train.torch_runtime import predict


@pytest.fixture()
def audio() -> np.ndarray:
    return np.random.default_rng(3).normal(size=(700, 26)).astype(np.float32)


def test_mlp_onnx_equals_torch(tmp_path: Path, audio: np.ndarray) -> None:
    torch.manual_seed(1)
    model = MLP(26, layers=7, units=8).eval()
    export_onnx(model, tmp_path)
    onnx_out = OnnxModel(tmp_path / MODEL_ONNX).predict(audio)
    assert onnx_out.shape == (700, 11)
    np.testing.assert_allclose(onnx_out, predict(model, audio), atol=1e-5, rtol=0)
    np.testing.assert_allclose(  # any number of frames
        OnnxModel(tmp_path / MODEL_ONNX).predict(audio[:1]), predict(model, audio[:1]), atol=1e-5
    )


def test_lstm_onnx_full_and_step_equal_torch(tmp_path: Path, audio: np.ndarray) -> None:
    torch.manual_seed(2)
    model = LSTMModel(26, units=12).eval()
    paths = export_onnx(model, tmp_path)
    assert [p.name for p in paths] == [MODEL_ONNX, STEP_ONNX]
    reference = predict(model, audio)
    full = OnnxModel(tmp_path / MODEL_ONNX).predict(audio)
    np.testing.assert_allclose(full, reference, atol=1e-5, rtol=0)
    stream = StreamingLSTM(tmp_path / STEP_ONNX)
    stepped = stream.run(audio)
    np.testing.assert_allclose(stepped, full, atol=1e-5, rtol=0)
    # The state carries over between calls; reset() starts again.
    stream.reset()
    first = stream.run(audio[:300])
    second = stream.run(audio[300:])
    np.testing.assert_allclose(np.concatenate([first, second]), full, atol=1e-5, rtol=0)
    stream.reset()
    np.testing.assert_allclose(stream.step(audio[0]), full[0], atol=1e-5, rtol=0)


def test_streaming_needs_a_step_model(tmp_path: Path) -> None:
    export_onnx(MLP(4, layers=7, units=8).eval(), tmp_path)
    with pytest.raises(InputError):
        StreamingLSTM(tmp_path / MODEL_ONNX)
    with pytest.raises(InputError):
        OnnxModel(tmp_path / "missing.onnx")
