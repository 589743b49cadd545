"""A plug-in model as a third-party package would write it, with its own `[train.gain]` section
(loaded through a patched "gesturebank.models" entry point in test_contract.py)."""

from __future__ import annotations

import torch
from pydantic import BaseModel, ConfigDict, Field
from torch import nn

from gesturebank.config import TrainConfig
from gesturebank.train.models.build import section
from gesturebank.train.schedule import Schedule


class GainSection(BaseModel):
    model_config = ConfigDict(extra="forbid")

    units: int = Field(4, ge=1)
    max_epochs: int = Field(2, ge=1)


class GainModel(nn.Module):
    """`(B, T, F)` → `(B, T, 11)`: one hidden layer per frame."""

    kind = "gain"
    causal = True
    config_sections = ("gain",)
    section_model = GainSection

    def __init__(self, n_features: int, units: int) -> None:
        super().__init__()
        self.n_features = n_features
        self.net = nn.Sequential(nn.Linear(n_features, units), nn.ReLU(), nn.Linear(units, 11))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.sigmoid(self.net(x))

    def schedule(self, config: TrainConfig) -> Schedule:
        own = section(config, GainModel, name="gain")
        assert isinstance(own, GainSection)
        return Schedule("adam", 0.01, None, own.max_epochs, 1, 20, 10, None, 0.01)
