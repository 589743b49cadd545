"""The two speech-to-motion models of the dissertation (§3.3, §4.3), sized by config.

- `MLP`: N_l hidden layers of N_u ReLU units, He-initialised, and a sigmoid output over the 11
  normalised angles (§4.3.3); frame-wise, `(N, F) → (N, 11)`.
- `LSTMModel`: one LSTM layer of N_u' units and a sigmoid dense output (§4.3.4), causal,
  `(B, T, F) → (B, T, 11)`, optionally from and to an explicit state (h, c) so that live
  synthesis can carry it between 10 ms frames (`LSTMStep`).
"""

from __future__ import annotations

import torch
from torch import nn

from gesturebank.config import TrainConfig
from gesturebank.train.schedule import Schedule

N_ANGLES = 11


class MLP(nn.Module):
    """`(N, F)` z-normalised audio features → `(N, 11)` angles in [0, 1]."""

    kind = "mlp"
    causal = True  # frame-wise: each output sees its own frame only
    frame_wise = True
    config_sections = ("mlp",)

    def __init__(self, n_features: int, layers: int, units: int) -> None:
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

    def schedule(self, config: TrainConfig) -> Schedule:
        lr = config.learning_rate
        return Schedule("adam", lr, config.mlp.batch_size, config.mlp.max_epochs,
                        config.patience, None, 1, None, lr)  # fmt: skip


class LSTMModel(nn.Module):
    """`(B, T, F)` → `(B, T, 11)` in [0, 1]; the state starts at zero unless given."""

    kind = "lstm"
    causal = True
    config_sections = ("lstm",)

    def __init__(self, n_features: int, units: int) -> None:
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

    def schedule(self, config: TrainConfig) -> Schedule:
        c, lr = config.lstm, config.learning_rate
        return Schedule("adam", lr, c.batch_size, c.max_epochs, config.patience,
                        c.seq_len, c.stride, None, lr)  # fmt: skip

    def step_module(self) -> tuple[nn.Module, list[tuple[int, ...]]]:
        """The one-frame graph for live mode and the shapes of its state inputs (h, c)."""
        return LSTMStep(self), [(1, 1, self.units), (1, 1, self.units)]


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
