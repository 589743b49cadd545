"""A 2D detection scored against a render's truth: how often the person is found, how far the
keypoints are (% of torso length), and how often left and right are swapped.

BlazePose puts its shoulder a few centimetres above a motion-capture upper-arm joint (and its
hips elsewhere than a mocap hip joint), so the error is also given after removing each joint's
constant offset (its median error vector over the take), which leaves what moves: the
detector's noise and its real mistakes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gesturebank.skeletons import COCO17

_I = COCO17.index
BODY = [
    _I[f"{side}_{j}"]
    for j in ("shoulder", "elbow", "wrist", "hip", "knee", "ankle")
    for side in ("left", "right")
]
# (left, right) index pairs of the body joints.
PAIRS = [(_I[f"left_{j}"], _I[f"right_{j}"]) for j in ("shoulder", "elbow", "wrist", "hip", "knee")]


@dataclass(frozen=True)
class Score2D:
    """found: share of frames with every body joint detected; error_pct, offset_free_pct:
    median distance of body joints (shoulders to ankles) to the truth, % of the truth's torso
    length (mid-shoulder to mid-hip), raw and with each joint's median error vector removed;
    swapped: share of found frames whose left and right sides fit the truth better exchanged."""

    found: float
    error_pct: float
    offset_free_pct: float
    swapped: float


def torso_px(joints2d: np.ndarray) -> np.ndarray:
    """(T,) mid-shoulder to mid-hip distance of (T, 17, 2) points."""
    shoulders = (joints2d[:, _I["left_shoulder"]] + joints2d[:, _I["right_shoulder"]]) / 2
    hips = (joints2d[:, _I["left_hip"]] + joints2d[:, _I["right_hip"]]) / 2
    return np.linalg.norm(shoulders - hips, axis=-1)


def score_2d(detected: np.ndarray, truth: np.ndarray) -> Score2D:
    """detected (T, 17, ≥2) px (NaN: not found), truth (T, 17, 2) px, frame for frame."""
    det = np.asarray(detected, np.float64)[..., :2]
    ref = np.asarray(truth, np.float64)
    if det.shape != ref.shape:
        raise ValueError(f"score_2d: detected {det.shape} and truth {ref.shape} differ")
    found = np.isfinite(det[:, BODY]).all(axis=(1, 2))
    if not found.any():
        return Score2D(found=0.0, error_pct=np.nan, offset_free_pct=np.nan, swapped=np.nan)
    torso = torso_px(ref)[found][:, None]
    delta = det[found][:, BODY] - ref[found][:, BODY]
    raw = np.linalg.norm(delta, axis=-1) / torso
    steady = delta - np.median(delta, axis=0)
    offset_free = np.linalg.norm(steady, axis=-1) / torso
    left, right = np.array(PAIRS).T
    same = np.linalg.norm(det[found][:, left] - ref[found][:, left], axis=-1)
    same += np.linalg.norm(det[found][:, right] - ref[found][:, right], axis=-1)
    crossed = np.linalg.norm(det[found][:, left] - ref[found][:, right], axis=-1)
    crossed += np.linalg.norm(det[found][:, right] - ref[found][:, left], axis=-1)
    return Score2D(
        found=float(found.mean()),
        error_pct=float(np.median(raw) * 100),
        offset_free_pct=float(np.median(offset_free) * 100),
        swapped=float((crossed.sum(axis=1) < same.sum(axis=1)).mean()),
    )


# The joints the lifters read (shoulders, elbows, wrists, hips): what the worst-joint error of
# the build's stored 2D is taken over (issue 39).
UPPER = [
    _I[f"{side}_{j}"] for j in ("shoulder", "elbow", "wrist", "hip") for side in ("left", "right")
]


def worst_joint_p90(detected: np.ndarray, truth: np.ndarray) -> float:
    """The worst joint's 90th percentile distance to the truth, % of the truth's torso length,
    over the UPPER joints of `detected (T, 17, ≥2)` px against `truth (T, 17, 2)` px, frame for
    frame. A joint not detected in a frame counts as lost (infinitely far): a detector does not
    improve by giving up on the hard frames. The percentile is the empirical one (the smallest
    error at least 90 % of the frames do not exceed), so a lost joint is never interpolated."""
    det = np.asarray(detected, np.float64)[:, UPPER, :2]
    ref = np.asarray(truth, np.float64)[:, UPPER]
    if det.shape != ref.shape:
        raise ValueError(f"worst_joint_p90: detected {det.shape} and truth {ref.shape} differ")
    error = np.linalg.norm(det - ref, axis=-1) / torso_px(np.asarray(truth, np.float64))[:, None]
    error = np.where(np.isfinite(error), error, np.inf)
    return float(100 * np.percentile(error, 90, axis=0, method="inverted_cdf").max())
