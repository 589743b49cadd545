"""Training loop (§3.3.3, §4.3): Adam on the masked MSE of normalised angles (= loss L, Eq. 3.15),
early stopping on the validation loss with patience, best weights restored.

Each model says how it is trained (`model.schedule(config)` → `Schedule`: optimiser, rate,
batches, epochs, training windows) and may define its own `loss`. With `lr_factor` set (seed
004) a stalled validation loss does not stop training at once: the best weights are reloaded and
the rate multiplied by `lr_factor`, down to `min_lr`; the next stall stops.

Deterministic on CPU: the seed fixes the initial weights and the shuffling (a numpy generator),
`torch.use_deterministic_algorithms` is on while training, and the thread count is fixed; the
same data and config give the same weights. Global torch settings are restored afterwards.

Validation loss: L over whole validation segments (`torch_runtime.validation_loss`), unless the
model has its own (`contract.OwnValidation`). The optional hooks are `train.contract`'s.
"""

from __future__ import annotations

import copy
import dataclasses
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import torch

from gesturebank.config import TrainConfig
from gesturebank.datasets.torch import FrameDataset, Segment, WindowDataset, masked_mse
from gesturebank.errors import InputError
from gesturebank.train.contract import OwnLoss, OwnValidation, SpeechToMotion, Staged
from gesturebank.train.schedule import Schedule, make_optimiser
from gesturebank.train.torch_runtime import torch_settings, validation_loss

log = logging.getLogger(__name__)

EARLY_STOP = "early stopping"
MAX_EPOCHS = "max epochs reached"


@dataclass
class TrainResult:
    best_epoch: int  # 1-based epoch whose weights were kept
    best_val_loss: float
    epochs: int  # epochs run
    seconds: float
    stopped: str  # EARLY_STOP or MAX_EPOCHS (of the last stage)
    max_epochs: int  # the epoch limit of the last stage
    history: list[dict[str, float]] = field(default_factory=list)  # epoch, train, val

    def stop_line(self) -> str:
        """'stopped: early stopping …' or 'stopped: max epochs reached …', for the user."""
        why = (
            "early stopping (the validation loss stopped falling)"
            if self.stopped == EARLY_STOP
            else f"{MAX_EPOCHS} ({self.max_epochs}); the validation loss may still be falling"
        )
        return (
            f"stopped: {why}; kept epoch {self.best_epoch} "
            f"(validation loss {self.best_val_loss:.5f})"
        )


class EpochProgress(Protocol):
    """Where a training run shows its epochs (the command's progress bar, `app.train_progress`;
    none: silently): `begin` once per stage, `epoch` after each, `end` with the epochs run."""

    def begin(self, description: str, max_epochs: int) -> None: ...

    def epoch(self, epoch: int, losses: str) -> None: ...

    def end(self, epochs: int) -> None: ...


def make_dataset(schedule: Schedule, segments: Sequence[Segment]) -> FrameDataset | WindowDataset:
    if schedule.seq_len is not None:
        return WindowDataset(segments, schedule.seq_len, schedule.stride)
    return FrameDataset(segments)


def train(
    model: torch.nn.Module,
    train_segments: Sequence[Segment],
    *,
    val_segments: Sequence[Segment],
    config: TrainConfig,
    progress: EpochProgress | None = None,
    description: str = "training",
    epochs: int | None = None,
) -> TrainResult:
    """Train `model` in place; its weights end as those of the best validation epoch.

    A model trained in stages (Aud2Repr2Pose: the motion DAE, then the speech encoder) has
    `stages(train_segments)`, which sets each stage up and yields its name; the stages run in
    turn, the result is the last one's, the history all of them (key "stage", from 0).

    `epochs` (`train --epochs`) replaces the schedule's `max_epochs`, of every stage.

    `progress` is shown each epoch's losses (None: nothing is shown).

    The model must have been created under the same seed for a fully reproducible run (the
    commands build it inside `torch_settings`).
    """
    if not isinstance(model, SpeechToMotion):
        raise InputError(f"{type(model).__name__}: not a speech-to-motion model (train.contract)")
    run = (model, train_segments, val_segments, config, progress)
    if not isinstance(model, Staged):
        return _train_stage(*run, description, epochs)
    done: list[TrainResult] = []
    for name in model.stages(train_segments):
        done.append(_train_stage(*run, f"{description} · {name}", epochs))
    history = [{**h, "stage": float(i)} for i, r in enumerate(done) for h in r.history]
    last = done[-1]
    return dataclasses.replace(
        last,
        epochs=sum(r.epochs for r in done),
        seconds=sum(r.seconds for r in done),
        history=history,
    )


def _masked_mse_of(
    model: torch.nn.Module,
) -> Callable[[torch.Tensor, torch.Tensor, torch.Tensor], torch.Tensor]:
    return lambda x, y, m: masked_mse(model(x), y, mask=m)


def _train_stage(
    model: torch.nn.Module,
    train_segments: Sequence[Segment],
    val_segments: Sequence[Segment],
    config: TrainConfig,
    progress: EpochProgress | None,
    description: str,
    epochs: int | None,
) -> TrainResult:
    assert isinstance(model, SpeechToMotion)  # checked by `train`
    schedule: Schedule = model.schedule(config)
    if epochs is not None:
        schedule = dataclasses.replace(schedule, max_epochs=epochs)
    data = make_dataset(schedule, train_segments)
    batch_size, max_epochs = schedule.batch_size or len(data), schedule.max_epochs
    loss_of = model.loss if isinstance(model, OwnLoss) else _masked_mse_of(model)
    rng = np.random.default_rng(config.seed)
    # a stage trains its part
    params = model.stage_parameters() if isinstance(model, Staged) else model.parameters()
    optimiser = make_optimiser(schedule, params)
    own_val = model.validation_loss if isinstance(model, OwnValidation) else None
    lr = schedule.learning_rate
    stalled_since = 0  # epoch of the last rate drop
    best = (float("inf"), 0, copy.deepcopy(model.state_dict()))
    history: list[dict[str, float]] = []
    start = time.perf_counter()
    epoch, stopped = 0, MAX_EPOCHS
    with torch_settings(config.seed, config.threads):
        if progress is not None:
            progress.begin(description, max_epochs)
        for epoch in range(1, max_epochs + 1):
            model.train()
            order = torch.from_numpy(rng.permutation(len(data)))
            total, weight = 0.0, 0.0
            for i in range(0, len(order), batch_size):
                x, y, m = data.batch(order[i : i + batch_size])
                optimiser.zero_grad()
                loss = loss_of(x, y, m)  # Eq. 3.15 on the known entries, or the model's own
                loss.backward()
                optimiser.step()
                n_known = float(m.sum())
                total += loss.item() * n_known
                weight += n_known
            train_loss = total / max(weight, 1.0)
            val_loss = own_val(val_segments) if own_val else validation_loss(model, val_segments)
            history.append(
                {"epoch": epoch, "train_loss": train_loss, "val_loss": val_loss, "lr": lr}
            )
            if val_loss < best[0]:
                best = (val_loss, epoch, copy.deepcopy(model.state_dict()))
            losses = f"train {train_loss:.5f}  val {val_loss:.5f}  best {best[0]:.5f}@{best[1]}"
            if progress is not None:
                progress.epoch(epoch, losses)
            if epoch - max(best[1], stalled_since) >= schedule.patience:
                lower = lr * schedule.lr_factor if schedule.lr_factor else 0.0
                if lower < schedule.min_lr * (1 - 1e-6):
                    stopped = EARLY_STOP
                    break
                model.load_state_dict(best[2])  # seed 004: back to the best, a tenth the rate
                lr, stalled_since = lower, epoch
                for group in optimiser.param_groups:
                    group["lr"] = lr
        if progress is not None:
            progress.end(epoch)
    model.load_state_dict(best[2])
    model.eval()
    seconds = time.perf_counter() - start
    log.info("%s: best val loss %.5f at epoch %d of %d", description, best[0], best[1], epoch)
    return TrainResult(best[1], best[0], epoch, seconds, stopped, max_epochs, history)
