"""Scores per role (issue 32, seed 004): how a model does on the frames where the clip's person
speaks, listens, or neither is known — seed 004 reports speakers and listeners apart.

Per role: the frames of that role in the scored segments, the known angle entries among them,
the loss L (Eq. 3.15: mean squared error of the normalised angles over the known entries) and
the RMSE of the angles in radians over the same entries. A role with no known entry has NaN
scores (a listener model's segments know only listening frames).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gesturebank.clip import ROLES
from gesturebank.datasets.torch import Segment


def per_role(
    segments: Sequence[Segment], *, pred01: Sequence[np.ndarray], angles: Sequence[np.ndarray]
) -> dict[str, dict[str, float]]:
    """role → {"frames", "known", "L", "rmse_rad"} of a model's predictions `pred01` (n, 11) in
    [0, 1] and `angles` (n, 11) rad (after post-processing), one of each per segment."""
    out = {}
    for code, name in enumerate(ROLES):
        frames, known, sq01, sq_rad = 0, 0, 0.0, 0.0
        for s, p01, a in zip(segments, pred01, angles, strict=True):
            role = np.zeros(len(s), np.int8) if s.role is None else s.role
            here = role == code
            mask = s.mask & here[:, None] & np.isfinite(s.angles)
            frames += int(here.sum())
            known += int(mask.sum())
            sq01 += float(np.sum((np.asarray(p01) - s.target)[mask] ** 2))
            sq_rad += float(np.sum((np.asarray(a) - s.angles)[mask] ** 2))
        out[name] = {
            "frames": float(frames),
            "known": float(known),
            "L": sq01 / known if known else float("nan"),
            "rmse_rad": float(np.sqrt(sq_rad / known)) if known else float("nan"),
        }
    return out
