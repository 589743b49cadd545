"""The scripts in examples/ run as a user runs them (a subprocess), on the real demo dataset."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
import wave
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.slow  # a subprocess that imports torch and trains: ~10 s of CPU
def test_first_dataset_plots_trains_and_synthesises(
    demo_dataset: Path, samples: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    speech = samples / "speech" / "arctic_a0007.wav"
    r = subprocess.run(
        [sys.executable, str(EXAMPLES / "first_dataset.py"), str(demo_dataset), str(out),
         "--speech", str(speech), "--epochs", "1"],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr

    image = matplotlib.image.imread(out / "clip.png")  # a real PNG, not an empty canvas
    assert image.ndim == 3 and image.shape[0] > 200 and image.shape[1] > 200
    assert image[..., :3].std() > 0.05

    assert (out / "model" / "model.onnx").is_file()

    info = json.loads((demo_dataset / "dataset.json").read_text())
    joints, limits = info["joints"], info["limits"]
    with open(out / "angles.csv", newline="") as f:
        rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
    header, body = rows[0], np.array(rows[1:], dtype=float)
    assert header[0] == "time_s" and header[1:] == joints and len(joints) == 11
    with wave.open(str(speech)) as w:
        seconds = w.getnframes() / w.getframerate()
    assert abs(len(body) - seconds * 100) <= 3  # one row per 10 ms of speech
    assert np.all(np.diff(body[:, 0]) > 0)
    low = np.array([limits[j]["lower"] for j in joints])
    high = np.array([limits[j]["upper"] for j in joints])
    assert np.all(np.isfinite(body[:, 1:]))
    assert np.all((body[:, 1:] >= low - 1e-5) & (body[:, 1:] <= high + 1e-5))
    assert np.ptp(body[:, 1:], axis=0).max() > 0  # the model moves the robot, at least a little
