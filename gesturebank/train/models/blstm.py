"""The BLSTM span predictor (seed 004, Greenwood et al.): a deep bidirectional LSTM over the n
frames around t predicts the k frames around t; every frame is the mean of the k predictions
that cover it. No smoothing afterwards (the overlap averages). Trained with seed 004's RMSprop
schedule. Non-causal: it needs n/2 + k/2 frames of future audio.
"""

from __future__ import annotations

import torch
from torch import nn

from gesturebank.config import TrainConfig
from gesturebank.errors import InputError
from gesturebank.train.models.layers import centre, span_mean, windows
from gesturebank.train.schedule import Schedule, rmsprop_schedule

N_ANGLES = 11


class SpanBLSTM(nn.Module):
    """`(B, T, F)` → `(B, T, 11)` in [0, 1]; n = `receptive`, k = `span` (both odd)."""

    kind = "blstm"
    causal = False
    config_sections = ("blstm",)

    def __init__(self, n_features: int, layers: int, units: int, receptive: int, span: int) -> None:
        super().__init__()
        if receptive % 2 == 0 or span % 2 == 0:
            raise InputError(
                f"train.blstm: receptive ({receptive}) and span ({span}) must be odd (centred)"
            )
        self.n_features, self.layers, self.units = n_features, layers, units
        self.receptive, self.span = receptive, span
        self.lstm = nn.LSTM(n_features, units, num_layers=layers, batch_first=True,
                            bidirectional=True)  # fmt: skip
        self.out = nn.Linear(2 * units, span * N_ANGLES)

    def spans(self, x: torch.Tensor) -> torch.Tensor:
        """`(B, T, F)` → `(B, T, k, 11)`: window t's prediction of frames t − k//2 … t + k//2."""
        b, t, _ = x.shape
        y, _ = self.lstm(windows(x, self.receptive // 2))
        return torch.sigmoid(self.out(centre(y))).reshape(b, t, self.span, N_ANGLES)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return span_mean(self.spans(x))

    def schedule(self, config: TrainConfig) -> Schedule:
        return rmsprop_schedule(config.blstm, config)
