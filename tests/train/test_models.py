"""The two architectures of §4.3: sizes, output range, He initialisation, causality, state."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from gesturebank.config import TrainConfig
from gesturebank.errors import InputError
from gesturebank.train.models.build import (
    architecture,
    build_model,
    from_architecture,
    n_parameters,
)
from gesturebank.train.models.dissertation import MLP, LSTMModel, LSTMStep
from gesturebank.train.torch_runtime import predict


def test_default_mlp_is_table_4_5_for_logfb26() -> None:
    model = build_model("mlp", 26, config=TrainConfig())
    assert isinstance(model, MLP)
    assert n_parameters(model) == 747  # Table 4.5: 7 × 8 for LogFB-26
    assert n_parameters(MLP(13, layers=5, units=8)) == 499  # MFCC-13 row
    assert n_parameters(MLP(52, layers=5, units=16)) == 2123  # LogFB-52 row


def test_outputs_are_eleven_angles_in_0_1() -> None:
    torch.manual_seed(0)
    x = 10 * torch.randn(50, 26)
    y = MLP(26, layers=7, units=8)(x)
    assert y.shape == (50, 11) and bool(((y >= 0) & (y <= 1)).all())
    lstm = LSTMModel(26, units=12)
    ys = lstm(x[None].repeat(2, 1, 1))
    assert ys.shape == (2, 50, 11) and bool(((ys >= 0) & (ys <= 1)).all())
    assert lstm.lstm.hidden_size == 12 and lstm.lstm.num_layers == 1


def test_he_initialisation() -> None:
    torch.manual_seed(0)
    model = MLP(400, layers=2, units=400)
    w = model.hidden[2].weight.detach()  # second hidden layer, fan-in 400
    assert float(w.std()) == pytest.approx(np.sqrt(2 / 400), rel=0.05)
    assert float(model.hidden[0].bias.detach().abs().max()) == 0.0


def test_lstm_is_causal_and_carries_its_state() -> None:
    torch.manual_seed(0)
    model = LSTMModel(5, units=4).eval()
    x = torch.randn(1, 40, 5)
    changed = x.clone()
    changed[:, 30:] += 3.0
    with torch.no_grad():
        full = model(x)
        assert torch.equal(model(changed)[:, :30], full[:, :30])  # the past ignores the future
        h = c = torch.zeros(1, 1, 4)
        first, h, c = model.forward_state(x[:, :25], h, c)
        second, _, _ = model.forward_state(x[:, 25:], h, c)
        torch.testing.assert_close(torch.cat([first, second], 1), full)
        step = LSTMStep(model)
        h = c = torch.zeros(1, 1, 4)
        outs = []
        for t in range(40):
            y, h, c = step(x[:, t], h, c)
            outs.append(y)
        torch.testing.assert_close(torch.stack(outs, 1), full)


def test_architecture_round_trip_and_predict() -> None:
    cfg = TrainConfig.model_validate({"mlp": {"layers": 3, "units": 16}, "lstm": {"units": 6}})
    for kind in ("mlp", "lstm"):
        model = build_model(kind, 10, config=cfg)
        rebuilt = from_architecture(architecture(model))
        rebuilt.load_state_dict(model.state_dict())  # same shapes
        audio = np.random.default_rng(0).normal(size=(30, 10)).astype(np.float32)
        np.testing.assert_array_equal(predict(model, audio), predict(rebuilt, audio))
        assert predict(model, audio).shape == (30, 11)
    assert architecture(build_model("mlp", 10, config=cfg)) == {
        "kind": "mlp",
        "n_features": 10,
        "layers": 3,
        "units": 16,
    }
    with pytest.raises(InputError):
        build_model("gru", 10, config=cfg)
