"""The two speech-to-motion models of the dissertation (§3.3, §4.3), sized by config.

- `MLP`: N_l hidden layers of N_u ReLU units, He-initialised, and a sigmoid output over the 11
  normalised angles (§4.3.3); frame-wise, `(N, F) → (N, 11)`.
- `LSTMModel`: one LSTM layer of N_u' units and a sigmoid dense output (§4.3.4), causal,
  `(B, T, F) → (B, T, 11)`, optionally from and to an explicit state (h, c) so that live
  synthesis can carry it between 10 ms frames (`LSTMStep`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from torch import nn

from gesturebank.config import ModelKind, TrainConfig
from gesturebank.errors import InputError

N_ANGLES = 11


class MLP(nn.Module):
    """`(N, F)` z-normalised audio features → `(N, 11)` angles in [0, 1]."""

    kind: ModelKind = "mlp"

    def __init__(self, n_features: int, layers: int = 7, units: int = 8) -> None:
        super().__init__()
        self.n_features = n_features
        blocks: list[nn.Module] = []
        width = n_features
        for _ in range(layers):
            linear = nn.Linear(width, units)
            nn.init.kaiming_normal_(linear.weight, nonlinearity="relu")  # He initialisation
            nn.init.zeros_(linear.bias)
            blocks += [linear, nn.ReLU()]
            width = units
        self.hidden = nn.Sequential(*blocks)
        self.out = nn.Linear(width, N_ANGLES)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.sigmoid(self.out(self.hidden(x)))  # σ_S, Eq. 3.7


class LSTMModel(nn.Module):
    """`(B, T, F)` → `(B, T, 11)` in [0, 1]; the state starts at zero unless given."""

    kind: ModelKind = "lstm"

    def __init__(self, n_features: int, units: int = 12) -> None:
        super().__init__()
        self.n_features = n_features
        self.units = units
        self.lstm = nn.LSTM(n_features, units, num_layers=1, batch_first=True)  # Eq. 3.9
        self.out = nn.Linear(units, N_ANGLES)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y, _ = self.lstm(x)
        return torch.sigmoid(self.out(y))

    def forward_state(
        self, x: torch.Tensor, h: torch.Tensor, c: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """x (B, T, F), h and c (1, B, units) → (y (B, T, 11), h', c')."""
        y, (h2, c2) = self.lstm(x, (h, c))
        return torch.sigmoid(self.out(y)), h2, c2


class LSTMStep(nn.Module):
    """One 10 ms step of an `LSTMModel`: (x (1, F), h (1, 1, U), c (1, 1, U)) → (y (1, 11), h', c').

    Running it frame after frame from zero state equals the full-sequence model on the same
    input; this is the graph exported for live synthesis.
    """

    def __init__(self, model: LSTMModel) -> None:
        super().__init__()
        self.model = model

    def forward(
        self, x: torch.Tensor, h: torch.Tensor, c: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        y, h2, c2 = self.model.forward_state(x[:, None, :], h, c)
        return y[:, 0, :], h2, c2


def build_model(kind: str, n_features: int, config: TrainConfig) -> MLP | LSTMModel:
    """A freshly initialised model of `kind` ('mlp' | 'lstm') for `n_features` inputs."""
    if kind == "mlp":
        return MLP(n_features, config.mlp.layers, config.mlp.units)
    if kind == "lstm":
        return LSTMModel(n_features, config.lstm.units)
    raise InputError(f"model must be 'mlp' or 'lstm', got {kind!r}")


def architecture(model: MLP | LSTMModel) -> dict[str, Any]:
    """Plain-data description from which `from_architecture` rebuilds the same module."""
    if isinstance(model, LSTMModel):
        return {"kind": "lstm", "n_features": model.n_features, "units": model.units}
    n_layers = sum(isinstance(m, nn.Linear) for m in model.hidden)
    units = model.out.in_features
    return {"kind": "mlp", "n_features": model.n_features, "layers": n_layers, "units": units}


def from_architecture(arch: dict[str, Any]) -> MLP | LSTMModel:
    if arch["kind"] == "mlp":
        return MLP(int(arch["n_features"]), int(arch["layers"]), int(arch["units"]))
    if arch["kind"] == "lstm":
        return LSTMModel(int(arch["n_features"]), int(arch["units"]))
    raise InputError(f"unknown model kind {arch['kind']!r}")


@torch.no_grad()
def predict(model: MLP | LSTMModel, audio: np.ndarray) -> np.ndarray:
    """Whole-segment prediction: z-normalised audio `(N, F)` → `(N, 11)` float32 in [0, 1].

    The LSTM runs over the whole segment from a zero state (as live synthesis does).
    """
    model.eval()
    x = torch.from_numpy(np.ascontiguousarray(audio, dtype=np.float32))
    y = model(x) if isinstance(model, MLP) else model(x[None])[0]
    return y.numpy()


def n_parameters(model: nn.Module) -> int:
    return sum(p.numel() for p in model.parameters())
