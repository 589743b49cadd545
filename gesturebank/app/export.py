"""The export command's work on arrays: 3D joints turned upright, samples put on a regular clock."""

from __future__ import annotations

from typing import Literal

import numpy as np

from gesturebank.skeletons import COCO17


def upright(joints: np.ndarray, *, layout: Literal["bvh", "opensim"]) -> np.ndarray:
    """`joints (T, 17, 3)` turned so that the body stands up: "bvh" → x left, y up, z forward;
    "opensim" → x forward, y up, z right (a rotation: right-handed stays right-handed)."""
    from gesturebank.mocap.pose import body_axes

    fwd, left, up = body_axes(joints)
    axes = np.stack([left, up, fwd]) if layout == "bvh" else np.stack([fwd, up, -left])
    centre = np.nanmedian(joints[:, [COCO17.index["left_hip"], COCO17.index["right_hip"]]], (0, 1))
    if not np.all(np.isfinite(centre)):
        centre = np.zeros(3)
    return (np.asarray(joints, np.float64) - centre) @ axes.T


def uniform(times: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """`values (T, …)` at `times (T,)` resampled linearly on a regular clock at the median rate:
    (times (N,), values (N, …), rate Hz). NaN stays NaN where it is interpolated from."""
    t = np.asarray(times, dtype=np.float64)
    if len(t) < 2:
        return t - t[0], np.asarray(values, np.float64), 100.0
    period = float(np.median(np.diff(t)))
    clock = t[0] + period * np.arange(int(np.floor((t[-1] - t[0]) / period + 1e-6)) + 1)
    flat = np.asarray(values, np.float64).reshape(len(t), -1)
    out = np.stack([np.interp(clock, t, flat[:, k]) for k in range(flat.shape[1])], axis=1)
    return clock - clock[0], out.reshape(len(clock), *np.shape(values)[1:]), 1.0 / period
