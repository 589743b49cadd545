"""Per-frame latency of live synthesis: MLP and stateful LSTM through onnxruntime, and features.

Each live 10 ms frame costs: LogFB-26 of the latest 400 samples (`frame_features`), then one
model call. The baseline is the dissertation's way of running an LSTM live (§5.1.2): re-run the
whole model on the last 300-frame window every frame — once through onnxruntime, once in eager
PyTorch (closest to its per-call Keras setup). All methods run in the same process, interleaved
in rounds; the table shows p50 / p99 / mean per frame in milliseconds over ≥ 10,000 frames each,
and how many times slower than the stateful LSTM step each one is.

A second table lists every registered model (`train.registry.MODELS`, default sizes,
untrained: same cost): causal ones as live mode runs them, one frame (plus state) per call;
non-causal ones (which cannot run live) as offline `synthesize` runs them, a whole utterance per
call, its time divided by its frames.

Usage: python benchmarks/inference.py [--frames 10000] [--rounds 5] [--model-dir DIR] [--quick]
(--model-dir: a trained model folder per kind, e.g. DIR/mlp and DIR/lstm; default: untrained
models of the default architectures, which cost exactly the same. --quick: 300 frames in one
round and 2 utterances of 1 s per non-causal model, to check that the script runs; it replaces
--frames and --rounds.)
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch
from rich.console import Console
from rich.table import Table

from gesturebank.audio.features import frame_features
from gesturebank.config import AudioConfig, TrainConfig
from gesturebank.train.export import OnnxModel, StreamingLSTM, export_onnx
from gesturebank.train.model_folder import MODEL_ONNX, STEP_ONNX, OnnxFrameModel
from gesturebank.train.models.build import build_model
from gesturebank.train.models.dissertation import LSTMModel
from gesturebank.train.registry import MODELS

WINDOW = 300  # N_τ frames the baseline re-runs every frame


def models(model_dir: Path | None, tmp: Path) -> tuple[Path, Path, LSTMModel]:
    """(MLP folder, LSTM folder, torch LSTM) — trained ones from model_dir, else fresh ones."""
    if model_dir is not None:
        from gesturebank.train.model_folder import load_model

        lstm, _, _ = load_model(model_dir / "lstm")
        assert isinstance(lstm, LSTMModel)
        return model_dir / "mlp", model_dir / "lstm", lstm
    torch.manual_seed(0)
    cfg = TrainConfig()
    export_onnx(build_model("mlp", 26, config=cfg), tmp / "mlp")
    lstm = build_model("lstm", 26, config=cfg)
    assert isinstance(lstm, LSTMModel)
    export_onnx(lstm, tmp / "lstm")
    return tmp / "mlp", tmp / "lstm", lstm


def time_calls(fn: Callable[[int], object], n: int, out: list[float]) -> None:
    for i in range(n):
        t0 = time.perf_counter_ns()
        fn(i)
        out.append((time.perf_counter_ns() - t0) / 1e6)


def _offset(fn: Callable[[int], object], offset: int, n: int) -> Callable[[int], object]:
    return lambda i: fn((offset + i) % n)


def every_model(
    tmp: Path, feats: np.ndarray, frames: int, utterances: int, seconds: float
) -> Table:
    """Per-frame latency of each registered model at its default size (module docstring)."""
    table = Table(title="Every model, default sizes, 1 thread (ms per frame)")
    for col in ("model", "mode", "p50", "p99", "mean"):
        table.add_column(col, justify="left" if col in ("model", "mode") else "right")
    cfg = TrainConfig()
    n_utt = int(seconds * 100)  # 100 frames per second
    for name in MODELS.names():
        torch.manual_seed(0)
        model = build_model(name, feats.shape[1], config=cfg).eval()
        folder = tmp / "every" / name
        paths = export_onnx(model, folder)
        times: list[float] = []
        if getattr(model, "causal", False):
            live = OnnxFrameModel(paths[-1])  # the step graph, or the MLP's frame graph

            def one_step(i: int, live: OnnxFrameModel = live) -> object:
                return live.step(feats[i % len(feats)])

            time_calls(one_step, 50, [])
            time_calls(one_step, frames, times)
            mode = "live: one step"
        else:
            offline = OnnxModel(folder / MODEL_ONNX)
            offline.predict(feats[:n_utt])  # warm-up
            for i in range(utterances):
                t0 = time.perf_counter_ns()
                offline.predict(feats[i : i + n_utt])
                times.append((time.perf_counter_ns() - t0) / 1e6 / n_utt)
            mode = f"offline, {seconds:g} s utterance ÷ frames"
        a = np.asarray(times)
        p50, p99 = np.percentile(a, [50, 99])
        table.add_row(name, mode, f"{p50:.3f}", f"{p99:.3f}", f"{a.mean():.3f}")
    table.caption = "offline rows: non-causal models, which need future audio and cannot run live"
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=10_000, help="frames per method (≥ 10,000)")
    parser.add_argument("--rounds", type=int, default=5, help="interleaved rounds")
    parser.add_argument("--model-dir", type=Path, default=None)
    parser.add_argument("--quick", action="store_true", help="300 frames, one round")
    args = parser.parse_args()
    if args.quick:
        args.frames, args.rounds = 300, 1
    torch.set_num_threads(1)

    rng = np.random.default_rng(0)
    audio_cfg = AudioConfig()
    signal = (0.1 * rng.normal(size=16000 * 5)).astype(np.float32)  # 5 s of noise-like audio
    feats = rng.normal(size=(args.frames + WINDOW, 26)).astype(np.float32)

    with tempfile.TemporaryDirectory() as tmp:
        mlp_dir, lstm_dir, lstm_torch = models(args.model_dir, Path(tmp))
        mlp = OnnxModel(mlp_dir / MODEL_ONNX)
        stream = StreamingLSTM(lstm_dir / STEP_ONNX)
        window_onnx = OnnxModel(lstm_dir / MODEL_ONNX)
        lstm_torch.eval()

        def features(i: int) -> object:
            a = (i * 160) % (len(signal) - 401) + 1
            return frame_features(
                signal[a : a + 400], 16000, config=audio_cfg, previous=float(signal[a - 1])
            )

        def window_torch(i: int) -> object:
            with torch.no_grad():
                return lstm_torch(torch.from_numpy(feats[None, i : i + WINDOW]))[0, -1]

        methods: dict[str, Callable[[int], object]] = {
            "features: frame_features (LogFB-26, 400 samples)": features,
            "MLP 7×8, onnxruntime, one frame": lambda i: mlp.predict(feats[i : i + 1]),
            "LSTM 12, onnxruntime, stateful step": lambda i: stream.step(feats[i]),
            "baseline: LSTM re-run on 300 frames, onnxruntime": lambda i: window_onnx.predict(
                feats[i : i + WINDOW]
            )[-1],
            "baseline: LSTM re-run on 300 frames, torch eager": window_torch,
        }
        for fn in methods.values():  # warm-up
            time_calls(fn, 50, [])
        times: dict[str, list[float]] = {name: [] for name in methods}
        per_round = -(-args.frames // args.rounds)
        for r in range(args.rounds):
            for name, fn in methods.items():
                time_calls(_offset(fn, r * per_round, args.frames), per_round, times[name])

    step = float(np.percentile(times["LSTM 12, onnxruntime, stateful step"], 50))
    table = Table(title=f"Per-frame latency (ms), {per_round * args.rounds} frames each, 1 thread")
    for col in ("method", "p50", "p99", "mean", "p50 / stateful step"):
        table.add_column(col, justify="left" if col == "method" else "right")
    for name, ts in times.items():
        a = np.asarray(ts)
        p50, p99 = np.percentile(a, [50, 99])
        table.add_row(name, f"{p50:.3f}", f"{p99:.3f}", f"{a.mean():.3f}", f"{p50 / step:.1f}×")
    Console(width=max(Console().width, 110)).print(table)
    mlp_p99 = np.percentile(times["MLP 7×8, onnxruntime, one frame"], 99)
    lstm_p99 = np.percentile(times["LSTM 12, onnxruntime, stateful step"], 99)
    verdict = "met" if max(mlp_p99, lstm_p99) <= 1.0 else "NOT met"
    print(f"target p99 ≤ 1 ms per model: {verdict} (MLP {mlp_p99:.3f} ms, LSTM {lstm_p99:.3f} ms)")
    with tempfile.TemporaryDirectory() as tmp:
        utterances, seconds = (2, 1.0) if args.quick else (20, 10.0)
        table = every_model(Path(tmp), feats, per_round * args.rounds, utterances, seconds)
    Console(width=max(Console().width, 110)).print(table)


if __name__ == "__main__":
    main()
