"""`loss.png` of a model folder: the training and validation loss per epoch (matplotlib, Agg).

Drawn from `TrainResult.history`; a model trained in stages (key "stage") gets one panel per
stage, since each stage has its own loss. The figure is a fixed `SIZE_PX` so that a report or a
test knows what it gets.
"""

from __future__ import annotations

import io
import os
from collections.abc import Sequence

from gesturebank.fileio import output_errors, write_bytes_atomic

SIZE_PX = (800, 500)  # width, height of loss.png
_DPI = 100


def loss_png(*, history: Sequence[dict[str, float]], title: str) -> bytes:
    """PNG bytes of train/validation loss against epoch, the best validation epoch marked."""
    # the Agg canvas directly, not pyplot: no display needed, the user's backend untouched
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    stages = sorted({int(h.get("stage", 0)) for h in history}) or [0]
    fig = Figure(figsize=(SIZE_PX[0] / _DPI, SIZE_PX[1] / _DPI), dpi=_DPI, layout="tight")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, len(stages), squeeze=False)[0]
    for ax, stage in zip(axes, stages, strict=True):
        rows = [h for h in history if int(h.get("stage", 0)) == stage]
        epochs = [h["epoch"] for h in rows]
        val = [h["val_loss"] for h in rows]
        ax.plot(epochs, [h["train_loss"] for h in rows], label="training", color="tab:blue")
        ax.plot(epochs, val, label="validation", color="tab:orange")
        if val:
            best = min(range(len(val)), key=val.__getitem__)
            ax.axvline(epochs[best], color="grey", linestyle=":", label=f"best ({epochs[best]:g})")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_xlabel("epoch")
        ax.set_ylabel("loss")
        if len(stages) > 1:
            ax.set_title(f"stage {stage + 1}")
        ax.grid(alpha=0.3)
        ax.legend()
    fig.suptitle(title)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=_DPI)
    return buffer.getvalue()


def write_loss_png(
    path: str | os.PathLike[str], *, history: Sequence[dict[str, float]], title: str
) -> None:
    with output_errors(path, "the loss plot"):
        write_bytes_atomic(path, loss_png(history=history, title=title))
