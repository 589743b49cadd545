"""How a model trains (`Schedule`), as each model's `schedule(config)` builds it from its section.

Two families: the seed-001/003 way and the dissertation's (Adam, early stopping at the shared
patience) and seed 004's (RMSprop from 1e-3; on a stall the best weights are reloaded and the
rate divided by 10, down to 1e-5; the next stall stops). The trainer runs either.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch

from gesturebank.config import TrainConfig
from gesturebank.errors import InputError


@dataclass(frozen=True)
class Schedule:
    """How one model trains; built by each model's `schedule(config)` from its config section."""

    optimizer: str  # "adam" | "rmsprop"
    learning_rate: float
    batch_size: int | None  # None: the whole training set per step
    max_epochs: int
    patience: int
    seq_len: int | None  # None: frame-wise pairs (MLP); else windows of this many frames
    stride: int
    lr_factor: float | None  # None: stop at the first stall
    min_lr: float


def adam_schedule(section: Any, config: TrainConfig) -> Schedule:
    """Adam with early stopping at the shared patience, sized by a sequence model's section."""
    return Schedule(
        optimizer="adam",
        learning_rate=section.learning_rate,
        batch_size=section.batch_size,
        max_epochs=section.max_epochs,
        patience=config.patience,
        seq_len=section.seq_len,
        stride=section.stride,
        lr_factor=None,
        min_lr=section.learning_rate,
    )


def rmsprop_schedule(section: Any, config: TrainConfig) -> Schedule:
    """Seed 004: RMSprop from 1e-3, patience 5, best weights reloaded and rate /10 to 1e-5."""
    r = config.rmsprop
    return Schedule(
        optimizer="rmsprop",
        learning_rate=r.learning_rate,
        batch_size=section.batch_size,
        max_epochs=section.max_epochs,
        patience=r.patience,
        seq_len=section.seq_len,
        stride=section.stride,
        lr_factor=r.factor,
        min_lr=r.min_lr,
    )


def make_optimiser(schedule: Schedule, params: Any) -> torch.optim.Optimizer:
    if schedule.optimizer == "adam":
        return torch.optim.Adam(params, lr=schedule.learning_rate)
    if schedule.optimizer == "rmsprop":  # Keras' RMSprop (seed 004): ρ 0.9, ε 1e-7
        return torch.optim.RMSprop(params, lr=schedule.learning_rate, alpha=0.9, eps=1e-7)
    raise InputError(f"optimizer must be 'adam' or 'rmsprop', got {schedule.optimizer!r}")
