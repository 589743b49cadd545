"""The seed papers' models: layer shapes, causality, span recombination, the KL term, sampling,
and ONNX graphs equal to the torch models (stepped ones too)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from gesturebank.config import TrainConfig
from gesturebank.errors import InputError
from gesturebank.train.export import OnnxModel, export_onnx
from gesturebank.train.model_folder import MODEL_ONNX, STEP_ONNX, OnnxFrameModel
from gesturebank.train.models.aud2motion import Aud2Motion, Aud2MotionStep
from gesturebank.train.models.aud2pose import Aud2Pose
from gesturebank.train.models.aud2repr2pose import Aud2Repr2Pose
from gesturebank.train.models.blstm import SpanBLSTM
from gesturebank.train.models.build import architecture, build_model, from_architecture
from gesturebank.train.models.cvae import CVAE, kl_to_standard_normal
from gesturebank.train.models.dcccae import DCCCAE, cca_correlation
from gesturebank.train.models.layers import span_mean, windows
from gesturebank.train.registry import MODELS
from gesturebank.train.torch_runtime import predict

SEED_MODELS = ("aud2motion", "aud2pose", "blstm", "cvae", "aud2repr2pose", "dcccae")
SMALL = TrainConfig.model_validate(
    {
        "aud2motion": {"units": 8},
        "aud2pose": {"units": 8, "context": 4},
        "blstm": {"units": 8, "receptive": 9, "span": 3},
        "cvae": {"units": 8},
        "dcccae": {
            "ae_units": 16,
            "code": 4,
            "regressor_units": 16,
            "post_code": 8,
            "post_context": 3,
        },
    }
)


def test_registry_lists_every_model() -> None:
    assert set(MODELS.names()) >= {"mlp", "lstm", *SEED_MODELS}
    with pytest.raises(InputError, match=r"unknown model 'gan' \(--model\); one of: aud2motion"):
        build_model("gan", 26, config=SMALL)


def test_default_layer_shapes_are_the_papers() -> None:
    cfg = TrainConfig()
    pose = build_model("aud2pose", 26, config=cfg)
    assert isinstance(pose, Aud2Pose)
    linears = [m for m in pose.fc.net if isinstance(m, torch.nn.Linear)]
    assert [(m.in_features, m.out_features) for m in linears] == [(26, 256), (256, 256), (256, 256)]
    assert sum(isinstance(m, torch.nn.BatchNorm1d) for m in pose.fc.net) == 3
    assert [m.p for m in pose.fc.net if isinstance(m, torch.nn.Dropout)] == [0.1] * 3
    assert pose.gru.bidirectional and pose.gru.hidden_size == 256
    assert pose.out.out_features == 22  # [g_t, Δg_t]
    assert pose.context == 30  # 61-frame windows
    motion = build_model("aud2motion", 26, config=cfg)
    assert isinstance(motion, Aud2Motion)
    assert not motion.gru.bidirectional and motion.gru.hidden_size == 256
    assert motion.out.out_features == 11  # no velocity output
    cvae = build_model("cvae", 26, config=cfg)
    assert isinstance(cvae, CVAE) and cvae.latent == 3
    assert cvae.encoder.bidirectional and cvae.decoder.bidirectional
    assert cvae.encoder.input_size == 11 + 26 and cvae.decoder.input_size == 26 + 3
    repr2pose = build_model("aud2repr2pose", 26, config=cfg)
    assert isinstance(repr2pose, Aud2Repr2Pose)
    assert repr2pose.motion_encoder[0].in_features == 22  # 11 angles + velocities
    assert repr2pose.speech_encoder.gru.hidden_size == 256  # SpeechE = the Aud2Pose network
    assert repr2pose.speech_encoder.out.out_features == repr2pose.code == 8
    dcc = build_model("dcccae", 26, config=cfg)
    assert isinstance(dcc, DCCCAE)
    assert dcc.speech_encoder[0].in_features == 7 * 26  # ±3-frame segments
    assert dcc.motion_encoder[0].in_features == dcc.motion_decoder[-1].out_features == 7 * 11
    assert dcc.regressor[0].in_features == dcc.regressor[-1].out_features == dcc.sizes["code"]
    span = build_model("blstm", 26, config=cfg)
    assert isinstance(span, SpanBLSTM) and span.lstm.bidirectional
    assert span.out.out_features == 5 * 11  # k frames per window

    x = torch.randn(2, 40, 26)
    small = {k: build_model(k, 26, config=SMALL).eval() for k in SEED_MODELS}
    with torch.no_grad():
        for kind, model in small.items():
            y = model(x)
            assert y.shape == (2, 40, 11), kind
            assert bool(((y >= 0) & (y <= 1)).all()), kind
        span_model, pose_model = small["blstm"], small["aud2pose"]
        assert isinstance(span_model, SpanBLSTM) and isinstance(pose_model, Aud2Pose)
        assert span_model.spans(x).shape == (2, 40, 3, 11)
        assert pose_model.heads(x).shape == (2, 40, 22)


def test_even_spans_are_refused() -> None:
    with pytest.raises(InputError, match="must be odd"):
        SpanBLSTM(26, layers=1, units=4, receptive=10, span=3)


def test_windows_and_span_mean() -> None:
    x = torch.arange(5.0).reshape(1, 5, 1)
    w = windows(x, 1)
    assert w.shape == (5, 3, 1)
    assert w[0, :, 0].tolist() == [0.0, 0.0, 1.0] and w[2, :, 0].tolist() == [1.0, 2.0, 3.0]
    # window t predicts frames t−1, t, t+1 as 100·t + offset: frame s averages what covers it
    t = torch.arange(5.0)[:, None] * 100 + torch.tensor([[-1.0, 0.0, 1.0]])
    mean = span_mean(t.reshape(1, 5, 3, 1))[0, :, 0]
    expected = [(0 + 99) / 2, (1 + 100 + 199) / 3, (101 + 200 + 299) / 3, (201 + 300 + 399) / 3,
                (301 + 400) / 2]  # fmt: skip
    torch.testing.assert_close(mean, torch.tensor(expected))


def test_aud2motion_is_causal_and_steps_like_the_whole_sequence() -> None:
    torch.manual_seed(0)
    model = Aud2Motion(6, fc_layers=3, units=8, dropout=0.1).eval()
    x = torch.randn(1, 50, 6)
    later = x.clone()
    later[:, 31:] += 5.0 * torch.randn(1, 19, 6)
    with torch.no_grad():
        full = model(x)
        moved = model(later)
        assert torch.equal(moved[:, :31], full[:, :31])  # output at t ≤ 30 ignores input after t
        assert not torch.allclose(moved[:, 31:], full[:, 31:])
        step, shapes = model.step_module()
        assert isinstance(step, Aud2MotionStep) and shapes == [(1, 1, 8)]
        h = torch.zeros(shapes[0])
        outs = []
        for t in range(50):
            y, h = step(x[:, t], h)
            outs.append(y)
        torch.testing.assert_close(torch.stack(outs, 1), full)


@pytest.mark.parametrize("kind", ["aud2pose", "blstm", "cvae", "aud2repr2pose", "dcccae"])
def test_the_others_use_future_audio(kind: str) -> None:
    torch.manual_seed(0)
    model = build_model(kind, 6, config=SMALL).eval()
    assert model.causal is False
    x = torch.randn(1, 40, 6)
    later = x.clone()
    later[:, 21:] += 5.0
    with torch.no_grad():
        assert not torch.allclose(model(later)[:, 18:21], model(x)[:, 18:21])


def test_kl_term_is_the_closed_form() -> None:
    gen = torch.Generator().manual_seed(0)
    mu, logvar = torch.randn(7, 3, generator=gen), torch.randn(7, 3, generator=gen)
    q = torch.distributions.Normal(mu, (0.5 * logvar).exp())
    p = torch.distributions.Normal(torch.zeros(3), torch.ones(3))
    reference = torch.distributions.kl_divergence(q, p).sum(-1)
    torch.testing.assert_close(kl_to_standard_normal(mu, logvar), reference)
    assert float(kl_to_standard_normal(torch.zeros(2, 3), torch.zeros(2, 3)).abs().max()) == 0.0
    # a Monte-Carlo estimate E_q[log q − log p] agrees too
    z = q.sample((20000,))
    mc = (q.log_prob(z) - p.log_prob(z)).sum(-1).mean(0)
    torch.testing.assert_close(mc, reference, atol=0.08, rtol=0.05)


def test_cvae_samples_differ_and_a_seed_repeats_them(tmp_path: Path) -> None:
    torch.manual_seed(0)
    model = build_model("cvae", 6, config=SMALL).eval()
    x = torch.randn(1, 30, 6)
    with torch.no_grad():
        a, b = model(x, torch.randn(1, 3)), model(x, torch.randn(1, 3))
        assert float((a - b).abs().max()) > 1e-3
    torch.manual_seed(0)
    again = build_model("cvae", 6, config=SMALL).eval()
    assert all(
        torch.equal(p, q) for p, q in zip(model.parameters(), again.parameters(), strict=True)
    )
    export_onnx(model, tmp_path)
    onnx = OnnxModel(tmp_path / MODEL_ONNX)
    audio = x[0].numpy()
    one, same, two = (onnx.predict(audio, z_seed=s) for s in (1, 1, 2))
    np.testing.assert_array_equal(one, same)
    assert np.abs(one - two).max() > 1e-3
    np.testing.assert_allclose(onnx.predict(audio), predict(model, audio), atol=1e-5)  # z = 0


@pytest.mark.parametrize("kind", SEED_MODELS)
def test_onnx_and_rebuilt_models_equal_torch(kind: str, tmp_path: Path) -> None:
    torch.manual_seed(1)
    model = build_model(kind, 26, config=SMALL).eval()
    rebuilt = from_architecture(architecture(model))
    rebuilt.load_state_dict(model.state_dict())
    audio = np.random.default_rng(2).normal(size=(120, 26)).astype(np.float32)
    reference = predict(model, audio)
    np.testing.assert_array_equal(predict(rebuilt, audio), reference)
    paths = export_onnx(model, tmp_path)
    np.testing.assert_allclose(
        OnnxModel(tmp_path / MODEL_ONNX).predict(audio), reference, atol=1e-5
    )
    if kind == "aud2motion":  # the live graph, stepped by live mode's frame model
        assert [p.name for p in paths] == [MODEL_ONNX, STEP_ONNX]
        live = OnnxFrameModel(tmp_path / STEP_ONNX)
        assert live.stateful and live.state_shapes == [(1, 1, 8)]
        stepped = np.stack([live.step(row) for row in audio])
        np.testing.assert_allclose(stepped, reference, atol=1e-5)
    else:
        assert [p.name for p in paths] == [MODEL_ONNX]


def numpy_cca(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Canonical correlations by QR (an independent route): singular values of Qa' Qb."""
    qa, _ = np.linalg.qr(a - a.mean(axis=0))
    qb, _ = np.linalg.qr(b - b.mean(axis=0))
    return np.linalg.svd(qa.T @ qb, compute_uv=False)


def correlated(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Two views sharing two latent signals, with noise and random mixing."""
    rng = np.random.default_rng(seed)
    shared = rng.normal(size=(n, 2))
    a = np.concatenate([shared, rng.normal(size=(n, 3))], axis=1) @ rng.normal(size=(5, 5))
    b = np.concatenate([shared, rng.normal(size=(n, 2))], axis=1) @ rng.normal(size=(4, 4))
    return a + 0.5 * rng.normal(size=a.shape), b + 0.5 * rng.normal(size=b.shape)


def test_cca_term_equals_numpy_cca() -> None:
    a, b = correlated(400, 0)
    reference = numpy_cca(a, b)
    assert reference[0] > 0.5  # the data are correlated: a non-trivial check
    value = cca_correlation(torch.from_numpy(a), torch.from_numpy(b), reg=0.0)
    assert float(value) == pytest.approx(reference.sum(), rel=1e-8)
    ridge = cca_correlation(torch.from_numpy(a), torch.from_numpy(b), reg=0.1)
    assert float(ridge) < float(value)  # the ridge shrinks the correlations


def test_optimising_the_cca_term_raises_the_correlation() -> None:
    a, b = correlated(500, 1)
    ta, tb = torch.from_numpy(a).float(), torch.from_numpy(b).float()
    gen = torch.Generator().manual_seed(0)
    wa = torch.randn(5, 2, generator=gen).requires_grad_()
    wb = torch.randn(4, 2, generator=gen).requires_grad_()

    def projected() -> float:
        with torch.no_grad():
            return float(numpy_cca((ta @ wa).numpy(), (tb @ wb).numpy()).sum())

    before = projected()
    optimiser = torch.optim.Adam([wa, wb], lr=0.05)
    for _ in range(300):
        optimiser.zero_grad()
        (-cca_correlation(ta @ wa, tb @ wb, reg=1e-4)).backward()
        optimiser.step()
    after = projected()
    best = float(numpy_cca(a, b)[:2].sum())  # the best two projections can reach
    assert after > before + 0.2
    assert after == pytest.approx(best, abs=0.02)
