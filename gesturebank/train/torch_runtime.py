"""What the models and the training loop share below both: torch's seed, threads and
determinism (`torch_settings`), whole-segment prediction and the validation loss L.

Validation loss: the model predicts every validation segment whole (`predict`; recurrent models
from a zero state, as in synthesis) and L is taken over all known entries. For the LSTM that is
~N_τ times cheaper than scoring every overlapping validation window, and it is the quantity that
matters when the model is used.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager

import numpy as np
import torch

from gesturebank.datasets.torch import Segment
from gesturebank.errors import InputError
from gesturebank.train.contract import FrameWise


@contextmanager
def torch_settings(seed: int, threads: int) -> Iterator[None]:
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


@torch.no_grad()
def predict(model: torch.nn.Module, audio: np.ndarray) -> np.ndarray:
    """Whole-segment prediction: z-normalised audio `(N, F)` → `(N, 11)` float32 in [0, 1].

    Sequence models run over the whole segment (recurrent ones from a zero state, as live
    synthesis does; the CVAE at z = 0, the prior's mean).
    """
    model.eval()
    x = torch.from_numpy(np.ascontiguousarray(audio, dtype=np.float32))
    y = model(x) if isinstance(model, FrameWise) else model(x[None])[0]
    return y.numpy()


def validation_loss(model: torch.nn.Module, segments: Sequence[Segment]) -> float:
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
