"""Training loop (§3.3.3, §4.3): Adam on the masked MSE of normalised angles (= loss L, Eq. 3.15),
early stopping on the validation loss with patience, best weights restored.

Deterministic on CPU: the seed fixes the initial weights and the shuffling (a numpy generator),
`torch.use_deterministic_algorithms` is on while training, and the thread count is fixed; the
same data and config give the same weights. Global torch settings are restored afterwards.

Validation loss: the model predicts every validation segment whole (`models.predict`; the LSTM
from a zero state, as in synthesis) and L is taken over all known entries. For the LSTM that is
~N_τ times cheaper than scoring every overlapping validation window, and it is the quantity that
matters when the model is used.
"""

from __future__ import annotations

import copy
import logging
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import torch
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from gesturebank.config import TrainConfig
from gesturebank.datasets.torch import FrameDataset, Segment, WindowDataset, masked_mse
from gesturebank.errors import InputError
from gesturebank.train.models import MLP, LSTMModel, predict

log = logging.getLogger(__name__)


@dataclass
class TrainResult:
    best_epoch: int  # 1-based epoch whose weights were kept
    best_val_loss: float
    epochs: int  # epochs run
    seconds: float
    history: list[dict[str, float]] = field(default_factory=list)  # epoch, train, val


@contextmanager
def torch_settings(seed: int, threads: int = 1) -> Iterator[None]:
    """Seed torch, fix its threads and make it deterministic; restore the settings on exit."""
    old_threads = torch.get_num_threads()
    old_det = torch.are_deterministic_algorithms_enabled()
    torch.set_num_threads(threads)
    torch.use_deterministic_algorithms(True)
    torch.manual_seed(seed)
    try:
        yield
    finally:
        torch.set_num_threads(old_threads)
        torch.use_deterministic_algorithms(old_det)


def validation_loss(model: MLP | LSTMModel, segments: Sequence[Segment]) -> float:
    """Loss L (Eq. 3.15) over the known entries of whole segments."""
    err = 0.0
    count = 0
    for s in segments:
        p = predict(model, s.audio)
        err += float(np.sum(((p - s.target) ** 2)[s.mask]))
        count += int(s.mask.sum())
    if count == 0:
        raise InputError("the validation segments have no known pose")
    return err / count


def make_dataset(
    model: MLP | LSTMModel, segments: Sequence[Segment], config: TrainConfig
) -> FrameDataset | WindowDataset:
    if isinstance(model, LSTMModel):
        return WindowDataset(segments, config.lstm.seq_len, config.lstm.stride)
    return FrameDataset(segments)


def train(
    model: MLP | LSTMModel,
    train_segments: Sequence[Segment],
    val_segments: Sequence[Segment],
    config: TrainConfig,
    *,
    quiet: bool = False,
    description: str = "training",
) -> TrainResult:
    """Train `model` in place; its weights end as those of the best validation epoch.

    The model must have been created under the same seed for a fully reproducible run (the
    commands build it inside `torch_settings`).
    """
    data = make_dataset(model, train_segments, config)
    if isinstance(model, LSTMModel):
        batch_size, max_epochs = config.lstm.batch_size, config.lstm.max_epochs
    else:
        batch_size, max_epochs = config.mlp.batch_size or len(data), config.mlp.max_epochs
    rng = np.random.default_rng(config.seed)
    optimiser = torch.optim.Adam(model.parameters(), lr=config.learning_rate)
    best = (float("inf"), 0, copy.deepcopy(model.state_dict()))
    history: list[dict[str, float]] = []
    start = time.perf_counter()
    progress = Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        TextColumn("epoch {task.completed:.0f}/{task.total:.0f}"),
        TextColumn("{task.fields[losses]}"),
        TimeElapsedColumn(),
        disable=quiet,
        transient=False,
    )
    epoch = 0
    with torch_settings(config.seed, config.threads), progress:
        task = progress.add_task(description, total=max_epochs, losses="")
        for epoch in range(1, max_epochs + 1):
            model.train()
            order = torch.from_numpy(rng.permutation(len(data)))
            total, weight = 0.0, 0.0
            for i in range(0, len(order), batch_size):
                x, y, m = data.batch(order[i : i + batch_size])
                optimiser.zero_grad()
                loss = masked_mse(model(x), y, m)  # Eq. 3.15 on the known entries
                loss.backward()
                optimiser.step()
                n_known = float(m.sum())
                total += loss.item() * n_known
                weight += n_known
            train_loss = total / max(weight, 1.0)
            val_loss = validation_loss(model, val_segments)
            history.append({"epoch": epoch, "train_loss": train_loss, "val_loss": val_loss})
            if val_loss < best[0]:
                best = (val_loss, epoch, copy.deepcopy(model.state_dict()))
            progress.update(
                task,
                completed=epoch,
                losses=f"train {train_loss:.5f}  val {val_loss:.5f}  best {best[0]:.5f}@{best[1]}",
            )
            if epoch - best[1] >= config.patience:
                break
        progress.update(task, total=epoch)
    model.load_state_dict(best[2])
    model.eval()
    seconds = time.perf_counter() - start
    log.info("%s: best val loss %.5f at epoch %d of %d", description, best[0], best[1], epoch)
    return TrainResult(best[1], best[0], epoch, seconds, history)
