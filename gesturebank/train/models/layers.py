"""Building blocks shared by the seed models: the FC stack of seed 001, per-frame windows, and
the mean recombination of overlapping span predictions (seed 004). Shapes are batch-first."""

from __future__ import annotations

import torch
from torch import nn


class FCStack(nn.Module):
    """Seed 001's input layers: per frame, `layers` × (Linear → BatchNorm → ReLU → Dropout);
    `(B, T, F)` → `(B, T, units)`. Frame-wise, so causal in eval mode."""

    def __init__(self, n_in: int, layers: int, units: int, dropout: float) -> None:
        super().__init__()
        blocks: list[nn.Module] = []
        width = n_in
        for _ in range(layers):
            blocks += [
                nn.Linear(width, units),
                nn.BatchNorm1d(units),
                nn.ReLU(),
                nn.Dropout(dropout),
            ]
            width = units
        self.net = nn.Sequential(*blocks)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        b, t, f = x.shape
        return self.net(x.reshape(b * t, f)).reshape(b, t, -1)


def windows(x: torch.Tensor, context: int) -> torch.Tensor:
    """`(B, T, F)` → `(B·T, 2·context + 1, F)`: the frames t−C … t+C around every t, zero past
    the ends (a many-to-one model slides this window over the sequence)."""
    b, t, f = x.shape
    width = 2 * context + 1
    padded = nn.functional.pad(x, (0, 0, context, context))
    rows = torch.arange(t)[:, None] + torch.arange(width)[None, :]  # (T, W) indices
    return padded[:, rows].reshape(b * t, width, f)


def span_mean(spans: torch.Tensor) -> torch.Tensor:
    """`(B, T, k, D)` — window t predicting frames t − k//2 … t + k//2 — → `(B, T, D)`, each
    frame the mean of the predictions that cover it (seed 004's recombination)."""
    t, k = spans.shape[1], spans.shape[2]
    h = k // 2
    padded = nn.functional.pad(spans, (0, 0, 0, 0, h, h))
    ones = nn.functional.pad(torch.ones_like(spans[..., :1]), (0, 0, 0, 0, h, h))
    total = torch.zeros_like(spans[:, :, 0])
    count = torch.zeros_like(spans[:, :, 0, :1])
    for j in range(k):  # window t + h − j predicts frame t at its offset j
        start = 2 * h - j
        total = total + padded[:, start : start + t, j]
        count = count + ones[:, start : start + t, j]
    return total / count


def centre(outputs: torch.Tensor) -> torch.Tensor:
    """The middle step of windowed recurrent outputs `(N, W, D)` → `(N, D)`."""
    return outputs[:, outputs.shape[1] // 2]
