"""How far a single-view lift's depth signs can be trusted, per frame, and what that costs.

A bone seen in one image has two 3D readings, towards and away from the camera
(`lift.depth_sign`); which one a lifter took is only as good as its evidence. What a wrong choice
costs grows with how far the bone leaves the image plane: a bone of full length L whose 2D
length is l has an out-of-plane share

    s = sqrt(1 − min(1, l / L)²)                                                           (1)

(0 in the image plane, 1 along the camera's ray), and its wrong reading puts its end 2·s·L away
from the right one. So a bone nearly in the image plane has an uncertain sign that costs little.

`out_of_plane_share` measures (1) from the 2D alone, lifter-independent: L in pixels is the
bone's length over the spine's in the lifted 3D (a proportion of the body, the clip's median)
times the spine's 2D length in the frame (mid-shoulders to mid-hips: upright and facing any way,
the spine stays near the image plane of a camera at chest height).

`depth_confidence` turns it into one number per frame in [0, 1]:

    confidence = 1 − max_b s_b                                                             (2)

over the four arm bones b (upper arms, forearms) seen in the frame: the bone furthest out of the
image plane decides, 1 with every arm bone in the plane, 0 with one along the camera's ray. A
bone not seen is not counted (its angles are masked, not guessed); a frame with no arm bone seen
is 1. Monotone: a bone further out of the plane never raises the confidence.

Chosen on the tuning renders (`benchmarks/depth_confidence.py --set tune`, BlazePose and
`blazepose-world`) by how well it ranks frames by their Pepper hand error (Spearman ρ): the
largest share −0.51, their mean −0.39; weighting each bone's share by the detector's visibility
of its end, s·(1 − e·v), gained nothing (−0.515 at e = 0.5, −0.46 at e = 0.9), so the
visibility is left out.

The detector's own relative depth is no evidence for `blazepose-world` (its
depth *is* BlazePose's), so it is not used either.

A `DepthCalibration` maps the confidence to what it meant on the project's own renders
(`benchmarks/depth_confidence.py`): the mean confidence of each bin, the share of
clearly-towards/away bones lifted with the wrong sign there, and the Pepper hand error (cm)
there. A lifter declares its own in its traits (`BLAZEPOSE_WORLD`, `LEARNED`, `RESOLVED` here);
`hand_error_cm` interpolates it; a lifter without one has no expectation.
"""

from __future__ import annotations

import warnings
from typing import NamedTuple

import numpy as np

from gesturebank.skeletons import COCO17

_I = COCO17.index
ARM_BONES = tuple(
    (_I[f"{side}_{a}"], _I[f"{side}_{b}"])
    for side in ("left", "right")
    for a, b in (("shoulder", "elbow"), ("elbow", "wrist"))
)
_SHOULDERS = [_I["left_shoulder"], _I["right_shoulder"]]
_HIPS = [_I["left_hip"], _I["right_hip"]]


def out_of_plane_share(*, xy: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """(T, 4) Eq. (1) per arm bone (`ARM_BONES` order) of COCO-17 pixels `xy` (T, 17, 2) and the
    lifted joints (T, 17, 3) (any metric frame; only bone proportions are read); NaN where the
    bone or the spine is unseen."""
    xy = np.asarray(xy, np.float64)
    joints = np.asarray(joints, np.float64)
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an unseen bone: all-NaN medians
        spine_px = np.linalg.norm(xy[:, _SHOULDERS].mean(1) - xy[:, _HIPS].mean(1), axis=-1)
        spine_3d = np.linalg.norm(joints[:, _SHOULDERS].mean(1) - joints[:, _HIPS].mean(1), axis=-1)
        out = np.full((len(xy), len(ARM_BONES)), np.nan)
        for k, (a, b) in enumerate(ARM_BONES):
            ratio = np.nanmedian(np.linalg.norm(joints[:, b] - joints[:, a], axis=-1) / spine_3d)
            bone_px = np.linalg.norm(xy[:, b] - xy[:, a], axis=-1)
            in_plane = np.clip(bone_px / (ratio * spine_px), 0.0, 1.0)
            out[:, k] = np.sqrt(1.0 - in_plane**2)
    return out


def depth_confidence(*, share: np.ndarray) -> np.ndarray:
    """(T,) float32 Eq. (2) in [0, 1] from the arm bones' out-of-plane shares (T, 4) (Eq. 1;
    NaN: unseen, not counted)."""
    s = np.nan_to_num(np.clip(np.asarray(share, np.float64), 0.0, 1.0), nan=0.0)
    return np.asarray(1.0 - s.max(axis=-1), dtype=np.float32)


def pose_confidence(*, xy: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """(T,) float32 depth confidence of one lifted view: COCO-17 pixels `xy` (T, 17, 2) and the
    lifted joints (T, 17, 3)."""
    return depth_confidence(share=out_of_plane_share(xy=xy, joints=joints))


class DepthCalibration(NamedTuple):
    """A lifter's depth confidence measured against truth, per confidence bin: the mean
    confidence of each bin, the share of clearly-towards/away arm bones lifted with the wrong
    sign there, the Pepper hand error cm there. A lifter that has one names it in its traits
    (`lift.LifterTraits.depth_calibration`)."""

    middles: tuple[float, ...]
    wrong_sign: tuple[float, ...]
    hand_cm: tuple[float, ...]


# Bins 0–0.1–0.2–0.3–0.4–0.5–0.6–0.8–1 of the tuning renders (test.bvh 0–10, 21–31 and 148–158 s
# at 0/30/60°, BlazePose, 2700 frames), made by
#     .venv/bin/python benchmarks/depth_confidence.py --set tune --lifter blazepose-world
# Mean expected against measured hand error, and Spearman ρ of confidence and hand error per
# frame: tune 10.9 / 10.8 cm, ρ −0.51; test.bvh 31–51 s (--set acceptance, 1800 frames)
# 11.2 / 8.8 cm, ρ −0.49; test2 0–10 s and test3 20–30 s (--set holdout, 1800 frames)
# 8.9 / 7.8 cm, ρ −0.11. Off the tuning stretches it over-predicts (errs towards caution), and
# on other motions it ranks frames only weakly.
BLAZEPOSE_WORLD = DepthCalibration(
    (0.052, 0.144, 0.245, 0.347, 0.452, 0.557, 0.700, 0.951),
    (0.221, 0.104, 0.115, 0.093, 0.122, 0.128, 0.102, 0.099),
    (13.93, 11.80, 11.34, 10.54, 10.80, 8.46, 7.51, 6.88),
)
# --lifter learned, same renders and detections: stretches its net was trained on (from the
# mocap, not these renders), so optimistic; its error hardly follows the confidence (the net
# reads depth from motion, not from a bone's 2D length)
LEARNED = DepthCalibration(
    (0.049, 0.139, 0.247, 0.357, 0.446, 0.551, 0.647),
    (0.01, 0.05, 0.07, 0.02, 0.02, 0.0, 0.0),
    (3.5, 5.0, 5.8, 4.5, 4.3, 3.3, 4.2),
)
# --lifter resolved, same renders and detections (its last bin holds 5 frames)
RESOLVED = DepthCalibration(
    (0.052, 0.141, 0.247, 0.350, 0.453, 0.545, 0.657, 0.836),
    (0.128, 0.068, 0.101, 0.108, 0.113, 0.102, 0.018, 0.0),
    (11.08, 8.98, 10.18, 8.81, 8.76, 7.49, 7.01, 8.43),
)


def hand_error_cm(*, confidence: np.ndarray, calibration: DepthCalibration | None) -> float:
    """Mean Pepper hand error (cm) that frames of `confidence` (T,) meant on the renders by a
    lifter's `calibration` (interpolated between its bins, held beyond them); NaN without a
    calibration or frames."""
    c = np.asarray(confidence, np.float64)
    if calibration is None or not len(c):
        return float("nan")
    return float(np.mean(np.interp(c, calibration.middles, calibration.hand_cm)))
