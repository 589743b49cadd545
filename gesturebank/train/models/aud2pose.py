"""Aud2Pose (seed 001's baseline, after Hasegawa et al. 2018): FC layers → BiGRU → linear.

Many-to-one: the pose at t comes from the window of frames t−C … t+C (FC per frame, the BiGRU
over the window, its middle step → the output); the window slides over the sequence. With
`velocity` the output is [g_t, Δg_t] and Δg_t (g_t − g_{t−1} of the targets) is a second MSE
term, a training regulariser only. Non-causal: it needs C frames of future audio.
"""

from __future__ import annotations

import torch
from torch import nn

from gesturebank.config import TrainConfig
from gesturebank.datasets.torch import masked_mse
from gesturebank.train.models.layers import FCStack, centre, windows
from gesturebank.train.schedule import Schedule, adam_schedule

N_ANGLES = 11


class Aud2Pose(nn.Module):
    """`(B, T, F)` → `(B, T, 11)` in [0, 1], each frame from its ±`context` window."""

    kind = "aud2pose"
    causal = False
    config_sections = ("aud2pose",)

    def __init__(
        self, n_features: int, fc_layers: int, units: int, dropout: float, context: int,
        velocity: bool,
    ) -> None:  # fmt: skip
        super().__init__()
        self.n_features, self.fc_layers, self.units = n_features, fc_layers, units
        self.dropout, self.context, self.velocity = dropout, context, velocity
        self.fc = FCStack(n_features, fc_layers, units, dropout)
        self.gru = nn.GRU(units, units, batch_first=True, bidirectional=True)
        self.drop = nn.Dropout(dropout)
        self.out = nn.Linear(2 * units, N_ANGLES * (2 if velocity else 1))

    def heads(self, x: torch.Tensor) -> torch.Tensor:
        """`(B, T, F)` → raw outputs `(B, T, 11 or 22)`: pose logits [, velocity]."""
        b, t, _ = x.shape
        y, _ = self.gru(windows(self.fc(x), self.context))
        return self.out(self.drop(centre(y))).reshape(b, t, -1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.sigmoid(self.heads(x)[..., :N_ANGLES])

    def loss(self, x: torch.Tensor, y: torch.Tensor, m: torch.Tensor) -> torch.Tensor:
        raw = self.heads(x)
        loss = masked_mse(torch.sigmoid(raw[..., :N_ANGLES]), y, mask=m)
        if self.velocity:  # Δg_t where both frames are known
            dm = m[:, 1:] & m[:, :-1]
            loss = loss + masked_mse(raw[:, 1:, N_ANGLES:], y[:, 1:] - y[:, :-1], mask=dm)
        return loss

    def schedule(self, config: TrainConfig) -> Schedule:
        return adam_schedule(config.aud2pose, config)
