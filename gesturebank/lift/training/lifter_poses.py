"""Variations of motion-capture stretches for the `learned` lifter's training (issue 30: "motion
capture plus anatomically sampled poses"): one take of one person teaches a network that person's
proportions and gestures only, so each stretch may get

- other proportions (`reproportion`): shoulder width, upper arm, forearm and head scaled about
  their parent joints, the same on both sides;
- other arm motion (`sample_arm`): an arm's upper-arm direction, elbow bend and bend plane drawn
  as smooth random curves inside anatomical ranges, in the torso's own frame, so the torso's
  motion stays the mocap's.

Functions over COCO-17 joints (T, 17, 3) in any right-handed world, metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from gesturebank.lift.depth_sign import torso_frame
from gesturebank.skeletons import COCO17

_I = COCO17.index
_FACE = [_I[j] for j in ("nose", "left_eye", "right_eye", "left_ear", "right_ear")]


@dataclass(frozen=True)
class Ranges:
    """How far the variations reach."""

    proportion: tuple[float, float] = (0.85, 1.15)  # a bone's length factor
    # the upper arm's angle from hanging straight down, and its direction about the body
    # (0° out to the side, 90° forward, beyond 90° across the front, below 0° behind), degrees
    raise_deg: tuple[float, float] = (0.0, 150.0)
    swing_deg: tuple[float, float] = (-30.0, 130.0)
    bend_deg: tuple[float, float] = (0.0, 140.0)  # elbow flexion
    plane_deg: tuple[float, float] = (-90.0, 90.0)  # the plane the forearm bends in
    smooth_frames: tuple[float, float] = (4.0, 20.0)  # σ of the curves' smoothing, frames


def reproportion(joints: np.ndarray, *, rng: np.random.Generator, ranges: Ranges) -> np.ndarray:
    """`joints` with shoulder width, upper arms, forearms and head scaled by random factors in
    `ranges.proportion`, each joint moved with its parent."""
    out = np.array(joints, dtype=np.float64)
    shoulders, upper, fore, head = rng.uniform(*ranges.proportion, size=4)
    neck = out[:, [_I["left_shoulder"], _I["right_shoulder"]]].mean(axis=1)
    out[:, _FACE] = neck[:, None] + head * (out[:, _FACE] - neck[:, None])
    for side in ("left", "right"):
        s, e, w = (_I[f"{side}_{j}"] for j in ("shoulder", "elbow", "wrist"))
        arm = out[:, [e, w]] - out[:, s][:, None]
        fore_v = out[:, w] - out[:, e]
        out[:, s] = neck + shoulders * (out[:, s] - neck)
        out[:, e] = out[:, s] + upper * arm[:, 0]
        out[:, w] = out[:, e] + fore * fore_v
    return out


def _curve(
    rng: np.random.Generator, frames: int, bounds: tuple[float, float], smooth: float
) -> np.ndarray:
    """(frames,) a smooth random curve wandering over `bounds`."""
    z = gaussian_filter1d(rng.normal(size=frames + 8 * int(smooth)), smooth)[4 * int(smooth) :]
    z = z[:frames] / (z.std() + 1e-9)
    lo, hi = bounds
    return lo + (hi - lo) * 0.5 * (1.0 + np.tanh(z + rng.normal(0.0, 0.7)))


def sample_arm(
    joints: np.ndarray, side: str, *, rng: np.random.Generator, ranges: Ranges
) -> np.ndarray:
    """`joints` with the `side` ("left"/"right") arm's elbow and wrist replaced by a random
    smooth motion of the same bone lengths, relative to the torso's frame."""
    out = np.array(joints, dtype=np.float64)
    s, e, w = (_I[f"{side}_{j}"] for j in ("shoulder", "elbow", "wrist"))
    mid_hip = out[:, [_I["left_hip"], _I["right_hip"]]].mean(axis=1)
    forward, left, up = torso_frame(out[:, _I["left_shoulder"]], out[:, _I["right_shoulder"]],
                                    mid_hip=mid_hip)  # fmt: skip
    outward = left if side == "left" else -left
    upper_len = float(np.nanmedian(np.linalg.norm(out[:, e] - out[:, s], axis=-1)))
    fore_len = float(np.nanmedian(np.linalg.norm(out[:, w] - out[:, e], axis=-1)))
    n = len(out)
    smooth = rng.uniform(*ranges.smooth_frames)
    raise_, swing, bend, plane = (
        np.deg2rad(_curve(rng, n, r, smooth))[:, None]
        for r in (ranges.raise_deg, ranges.swing_deg, ranges.bend_deg, ranges.plane_deg)
    )
    upper = -np.cos(raise_) * up + np.sin(raise_) * (
        np.cos(swing) * outward + np.sin(swing) * forward
    )
    # the bend plane: turned about the upper arm from "forward and up" by `plane`
    toward = np.cos(plane) * forward + np.sin(plane) * up
    toward = toward - np.sum(toward * upper, -1, keepdims=True) * upper
    toward /= np.linalg.norm(toward, axis=-1, keepdims=True) + 1e-12
    fore = np.cos(bend) * upper + np.sin(bend) * toward
    out[:, e] = out[:, s] + upper_len * upper
    out[:, w] = out[:, e] + fore_len * fore
    return out
