"""Live-mode per-frame latency: stateful one-step LSTM vs re-running a 300-frame window (the
dissertation's LSTM baseline, §5.1.2), and the MLP; then a real-time end-to-end run on real speech.

Models are tiny random-weight torch models exported to ONNX (tests/robot/tiny_models.py), with the
dissertation's sizes (LSTM 12 units; MLP one hidden layer of 64). The speech is the project's
sample `speech/arctic_a0007.wav`. Run: .venv/bin/python benchmarks/live.py
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "robot"))
from tiny_models import write_model_dir

from gesturebank.config import AudioConfig
from gesturebank.extract.audio import apply_znorm, features
from gesturebank.extract.video import read_audio
from gesturebank.robot.online import LiveSynth, live_command, load_frame_model
from gesturebank.samples import default_samples_dir, fetch_samples

WINDOW = 300


def pct(ms: list[float]) -> str:
    p50, p99 = np.percentile(ms, [50, 99])
    return f"{p50:>10.3f}{p99:>10.3f}"


def main() -> None:
    root = default_samples_dir()
    fetch_samples(root)
    wav = root / "speech" / "arctic_a0007.wav"
    track = read_audio(wav, 16000)
    assert track is not None
    signal = track.signal
    feats = features(signal, 16000, AudioConfig())
    hop = 160
    chunks = [signal[k * hop : (k + 1) * hop] for k in range(len(signal) // hop)]
    tmp = Path(tempfile.mkdtemp())
    lstm_dir = write_model_dir(tmp / "lstm", kind="lstm", hidden=12, feats=feats, window=WINDOW)
    mlp_dir = write_model_dir(tmp / "mlp", kind="mlp", hidden=64, feats=feats)
    rows: list[tuple[str, str]] = []

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
        rows.append((name, pct(ms)))

    # Baseline: the same LSTM re-run over the last 300 frames (zero-padded) at every frame.
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = 1
    sess = ort.InferenceSession(
        str(lstm_dir / "window.onnx"), opts, providers=["CPUExecutionProvider"]
    )
    model = load_frame_model(lstm_dir)
    z = apply_znorm(feats, model.audio_mean, model.audio_std)
    buf = np.zeros((1, WINDOW, z.shape[1]), np.float32)
    ms = []
    for row in z:
        t = time.perf_counter()
        buf[0, :-1] = buf[0, 1:]
        buf[0, -1] = row
        sess.run(None, {"x": buf})
        ms.append((time.perf_counter() - t) * 1000)
    rows.append(("LSTM 300-frame window (model only)", pct(ms)))
    step_ms = []
    for row in z:
        t = time.perf_counter()
        model.model.step(row)
        step_ms.append((time.perf_counter() - t) * 1000)
    rows.append(("LSTM step (model only)", pct(step_ms)))

    for name, folder in (
        ("MLP real time, record backend", mlp_dir),
        ("LSTM real time, record backend", lstm_dir),
    ):
        result = live_command(folder, "record", str(wav), out=tmp / "live.jsonl")
        p50, p99 = result.latency_ms()
        rows.append(
            (f"{name} ({result.n_sent} fr, {result.skipped} skipped)", f"{p50:>10.3f}{p99:>10.3f}")
        )

    print(f"{'per-frame latency':<52}{'p50 ms':>10}{'p99 ms':>10}")
    for name, cells in rows:
        print(f"{name:<52}{cells}")


if __name__ == "__main__":
    main()
