"""Which keypoints and frames of a repaired pose are worth keeping: keypoints that still spike
after the repair, frames without a torso and a face or an elbow."""

from __future__ import annotations

import numpy as np

from gesturebank.qc.metrics import spike_sizes
from gesturebank.skeletons import COCO17

_I = COCO17.index


def still_spiking(points: np.ndarray, valid: np.ndarray, *, max_spike: float) -> np.ndarray:
    """`(T, 17)` COCO-17 keypoints of `points (T, 17, C)` that, seen (`valid`), still jump out
    and back by more than `max_spike` shoulder widths in one frame (what repair left)."""
    seen = np.where(valid[..., None], np.asarray(points, np.float64), np.nan)
    out = np.zeros(valid.shape, dtype=bool)
    with np.errstate(invalid="ignore"):
        out[1:-1] = spike_sizes(seen, COCO17.joints) > max_spike
    return out


def usable_frames(valid: np.ndarray) -> np.ndarray:
    """`(T,)` frames whose pose is worth keeping: both shoulders seen, and the face or an elbow
    (`valid (T, 17)` COCO-17). Other frames inside a clip are masked; long runs end it."""
    torso = valid[:, _I["left_shoulder"]] & valid[:, _I["right_shoulder"]]
    face = valid[:, [_I["nose"], _I["left_eye"], _I["right_eye"]]].all(axis=1)
    arm = valid[:, _I["left_elbow"]] | valid[:, _I["right_elbow"]]
    return np.asarray(torso & (face | arm))
