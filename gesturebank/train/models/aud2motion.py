"""Aud2Motion (seed 001, Kucherenko et al.): FC layers → one causal, unidirectional GRU → linear.

Many-to-many: one pose per audio frame, trained on fixed chunks, run on whole sequences. The
output at t depends on frames ≤ t only, so it also runs live one frame at a time, carrying the
GRU state (`Aud2MotionStep`). The output goes through a sigmoid because targets are angles in
[0, 1] (the paper's were standardised coordinates with a linear output).
"""

from __future__ import annotations

import torch
from torch import nn

from gesturebank.config import TrainConfig
from gesturebank.train.models.layers import FCStack
from gesturebank.train.schedule import Schedule, adam_schedule

N_ANGLES = 11


class Aud2Motion(nn.Module):
    """`(B, T, F)` → `(B, T, 11)` in [0, 1], causal; the state starts at zero unless given."""

    kind = "aud2motion"
    causal = True
    config_sections = ("aud2motion",)

    def __init__(self, n_features: int, fc_layers: int, units: int, dropout: float) -> None:
        super().__init__()
        self.n_features, self.fc_layers, self.units, self.dropout = (
            n_features, fc_layers, units, dropout
        )  # fmt: skip
        self.fc = FCStack(n_features, fc_layers, units, dropout)
        self.gru = nn.GRU(units, units, batch_first=True)
        self.drop = nn.Dropout(dropout)
        self.out = nn.Linear(units, N_ANGLES)

    def forward_state(self, x: torch.Tensor, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """x (B, T, F), h (1, B, units) → (y (B, T, 11), h')."""
        y, h2 = self.gru(self.fc(x), h)
        return torch.sigmoid(self.out(self.drop(y))), h2

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = x.new_zeros(1, x.shape[0], self.units)
        return self.forward_state(x, h)[0]

    def schedule(self, config: TrainConfig) -> Schedule:
        return adam_schedule(config.aud2motion, config)

    def step_module(self) -> tuple[nn.Module, list[tuple[int, ...]]]:
        """The one-frame graph for live mode and the shape of its state input h."""
        return Aud2MotionStep(self), [(1, 1, self.units)]


class Aud2MotionStep(nn.Module):
    """One frame: (x (1, F), h (1, 1, U)) → (y (1, 11), h'); frame after frame from h = 0 it
    equals the whole-sequence model."""

    def __init__(self, model: Aud2Motion) -> None:
        super().__init__()
        self.model = model

    def forward(self, x: torch.Tensor, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        y, h2 = self.model.forward_state(x[:, None, :], h)
        return y[:, 0, :], h2
