"""Tiny torch models exported to ONNX in the model-folder layout `gesturebank train` writes.

For the tests and `benchmarks/live.py`: random weights (seeded), exported
with torch's TorchScript ONNX exporter, stats from real features when given.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import torch
from torch import nn

from gesturebank.config import AudioConfig

N_JOINTS = 11


class StepLSTM(nn.Module):
    """One LSTM step: x (1, F), h (1, 1, H), c (1, 1, H) → y (1, 11) in (0, 1), h_out, c_out."""

    def __init__(self, n_features: int, hidden: int) -> None:
        super().__init__()
        self.lstm = nn.LSTM(n_features, hidden, batch_first=True)
        self.head = nn.Linear(hidden, N_JOINTS)

    def forward(
        self, x: torch.Tensor, h: torch.Tensor, c: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        out, (h2, c2) = self.lstm(x[:, None, :], (h, c))
        return torch.sigmoid(self.head(out[:, -1])), h2, c2


class WindowLSTM(nn.Module):
    """The same LSTM over a whole window x (1, T, F) from a zero state → y (1, 11) (last frame)."""

    def __init__(self, step: StepLSTM) -> None:
        super().__init__()
        self.lstm, self.head = step.lstm, step.head

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        out, _ = self.lstm(x)
        return torch.sigmoid(self.head(out[:, -1]))


class MLP(nn.Module):
    def __init__(self, n_features: int, hidden: int) -> None:
        super().__init__()
        self.net = nn.Sequential(
            nn.Linear(n_features, hidden), nn.ReLU(), nn.Linear(hidden, N_JOINTS), nn.Sigmoid()
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x)


def _export(module: nn.Module, args: tuple[torch.Tensor, ...], path: Path, **kw: object) -> None:
    module.eval()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(module, args, str(path), dynamo=False, opset_version=17, **kw)  # type: ignore[arg-type]


def write_model_dir(
    folder: Path,
    *,
    kind: str = "lstm",
    n_features: int = 26,
    hidden: int = 12,
    feats: np.ndarray | None = None,
    seed: int = 0,
    window: int | None = None,
) -> Path:
    """Write the ONNX model, model.json and normalisers.json (and, with `window`, window.onnx)."""
    folder.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(seed)
    if kind == "lstm":
        model: nn.Module = StepLSTM(n_features, hidden)
        zeros = torch.zeros(1, 1, hidden)
        _export(
            model,
            (torch.zeros(1, n_features), zeros, zeros),
            folder / "model_step.onnx",
            input_names=["x", "h", "c"],
            output_names=["y", "h_out", "c_out"],
        )
        if window:
            _export(
                WindowLSTM(model),  # type: ignore[arg-type]
                (torch.zeros(1, window, n_features),),
                folder / "window.onnx",
                input_names=["x"],
                output_names=["y"],
            )
    else:
        _export(
            MLP(n_features, hidden),
            (torch.zeros(1, n_features),),
            folder / "model.onnx",
            input_names=["x"],
            output_names=["y"],
        )
    mean = feats.mean(axis=0) if feats is not None else np.zeros(n_features)
    std = feats.std(axis=0) if feats is not None else np.ones(n_features)
    stats = {"mean": [float(v) for v in mean], "std": [float(v) for v in std]}
    norm = {"audio_znorm_by_subject": {"*": stats}, "robot_profile": "pepper-1.7"}
    (folder / "normalisers.json").write_text(json.dumps(norm), encoding="utf-8")
    audio = AudioConfig(features="logfb26").model_dump(mode="json")
    (folder / "model.json").write_text(json.dumps({"audio": audio}), encoding="utf-8")
    return folder
