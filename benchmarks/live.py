"""Live-mode per-frame latency: stateful one-step LSTM vs re-running a 300-frame window (the
dissertation's LSTM baseline, §5.1.2), and the MLP; then a real-time end-to-end run on real speech.

Models are tiny random-weight torch models exported to ONNX (gesturebank/testing/tiny_models.py),
with the dissertation's sizes (LSTM 12 units; MLP one hidden layer of 64). The speech is the
project's sample `speech/arctic_a0007.wav`. Run: .venv/bin/python benchmarks/live.py [--quick]

--quick: the first second of the speech (a few seconds in all), to check that the script runs.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table
from scipy.io import wavfile

from gesturebank.app.robot import load_frame_model
from gesturebank.audio.features import apply_znorm, features
from gesturebank.audio.io import read_audio
from gesturebank.cli.robot import live_command
from gesturebank.config import AudioConfig
from gesturebank.robot.online import LiveSynth
from gesturebank.samples import default_samples_dir, fetch_samples
from gesturebank.testing.tiny_models import write_model_dir

WINDOW = 300
SPEECH = "speech/arctic_a0007.wav"
QUICK_S = 1.0  # --quick: seconds of speech used


def pct(ms: list[float] | np.ndarray) -> tuple[str, str]:
    p50, p99 = np.percentile(ms, [50, 99])
    return f"{p50:.3f}", f"{p99:.3f}"


def speech() -> Path:
    root = default_samples_dir()
    if not (root / SPEECH).is_file():  # fetching re-checks every sample's checksum: only if needed
        fetch_samples(root)
    return root / SPEECH


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help=f"the first {QUICK_S:g} s of speech")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        rows = measure(speech(), Path(folder), args.quick)
    table = Table(title="Live mode, per-frame latency (ms)")
    for col in ("per-frame latency", "p50 ms", "p99 ms"):
        table.add_column(col, justify="left" if col == "per-frame latency" else "right")
    for row in rows:
        table.add_row(*row)
    Console(width=max(Console().width, 90)).print(table)


def measure(wav: Path, tmp: Path, quick: bool) -> list[tuple[str, str, str]]:
    track = read_audio(wav, sample_rate=16000)
    assert track is not None
    signal = track.signal
    if quick:  # the real-time runs read a file: give them the same short speech
        signal = signal[: int(QUICK_S * 16000)]
        wav = tmp / "speech.wav"
        wavfile.write(wav, 16000, (np.clip(signal, -1, 1) * 32767).astype(np.int16))
    feats = features(signal, 16000, config=AudioConfig())
    hop = 160
    chunks = [signal[k * hop : (k + 1) * hop] for k in range(len(signal) // hop)]
    lstm_dir = write_model_dir(tmp / "lstm", kind="lstm", hidden=12, feats=feats, window=WINDOW)
    mlp_dir = write_model_dir(tmp / "mlp", kind="mlp", hidden=64, feats=feats)
    rows: list[tuple[str, str, str]] = []

    for name, folder in (
        ("MLP step (full pipeline)", mlp_dir),
        ("LSTM step (full pipeline)", lstm_dir),
    ):
        synth = LiveSynth(load_frame_model(folder))
        ms = []
        for c in chunks:
            t = time.perf_counter()
            synth.push(c)
            ms.append((time.perf_counter() - t) * 1000)
        rows.append((name, *pct(ms)))

    # Baseline: the same LSTM re-run over the last 300 frames (zero-padded) at every frame.
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = 1
    sess = ort.InferenceSession(
        str(lstm_dir / "window.onnx"), opts, providers=["CPUExecutionProvider"]
    )
    model = load_frame_model(lstm_dir)
    z = apply_znorm(feats, model.audio_mean, std=model.audio_std)
    buf = np.zeros((1, WINDOW, z.shape[1]), np.float32)
    ms = []
    for row in z:
        t = time.perf_counter()
        buf[0, :-1] = buf[0, 1:]
        buf[0, -1] = row
        sess.run(None, {"x": buf})
        ms.append((time.perf_counter() - t) * 1000)
    rows.append(("LSTM 300-frame window (model only)", *pct(ms)))
    step_ms = []
    for row in z:
        t = time.perf_counter()
        model.model.step(row)
        step_ms.append((time.perf_counter() - t) * 1000)
    rows.append(("LSTM step (model only)", *pct(step_ms)))

    for name, folder in (
        ("MLP real time, record backend", mlp_dir),
        ("LSTM real time, record backend", lstm_dir),
    ):
        result = live_command(folder, backend="record", input=str(wav), out=tmp / "live.jsonl")
        p50, p99 = result.latency_ms()
        label = f"{name} ({result.n_sent} fr, {result.skipped} skipped)"
        rows.append((label, f"{p50:.3f}", f"{p99:.3f}"))
    return rows


if __name__ == "__main__":
    main()
