"""Variations of training poses for the learned lifter (lift.training.lifter_poses): bones
keep their lengths or scale by the drawn factor, the torso is untouched, a sampled arm stays in
its anatomical ranges."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from gesturebank.lift.depth_sign import torso_frame
from gesturebank.lift.training.lifter_poses import Ranges, reproportion, sample_arm
from gesturebank.skeletons import COCO17

_I = COCO17.index
TORSO = [_I[j] for j in ("left_shoulder", "right_shoulder", "left_hip", "right_hip")]


def _person(rng: np.random.Generator, frames: int) -> np.ndarray:
    """A standing person (z up, facing −y) swaying a little, arms hanging, at random spots."""
    base = np.zeros((17, 3))
    for name, xyz in {
        "nose": (0, -0.1, 1.65), "left_eye": (0.03, -0.08, 1.68), "right_eye": (-0.03, -0.08, 1.68),
        "left_ear": (0.07, 0, 1.66), "right_ear": (-0.07, 0, 1.66),
        "left_shoulder": (0.18, 0, 1.45), "right_shoulder": (-0.18, 0, 1.45),
        "left_elbow": (0.2, 0, 1.15), "right_elbow": (-0.2, 0, 1.15),
        "left_wrist": (0.22, -0.05, 0.9), "right_wrist": (-0.22, -0.05, 0.9),
        "left_hip": (0.1, 0, 0.95), "right_hip": (-0.1, 0, 0.95),
        "left_knee": (0.1, 0, 0.5), "right_knee": (-0.1, 0, 0.5),
        "left_ankle": (0.1, 0, 0.05), "right_ankle": (-0.1, 0, 0.05),
    }.items():  # fmt: skip
        base[_I[name]] = xyz
    drift = np.cumsum(rng.normal(0, 0.005, (frames, 1, 3)), axis=0)
    return base[None] + drift + rng.uniform(-2, 2, (1, 1, 3))


def _length(j: np.ndarray, a: str, b: str) -> np.ndarray:
    return np.linalg.norm(j[:, _I[a]] - j[:, _I[b]], axis=-1)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), frames=st.integers(20, 80))
def test_reproportion_scales_each_bone_within_the_range_and_keeps_its_direction(
    seed: int, frames: int
) -> None:
    rng = np.random.default_rng(seed)
    joints = _person(rng, frames)
    out = reproportion(joints, rng=rng, ranges=Ranges())
    lo, hi = Ranges().proportion
    assert np.allclose(out[:, TORSO[2:]], joints[:, TORSO[2:]])  # hips stay
    for side in ("left", "right"):
        for a, b in (("shoulder", "elbow"), ("elbow", "wrist")):
            before = joints[:, _I[f"{side}_{b}"]] - joints[:, _I[f"{side}_{a}"]]
            after = out[:, _I[f"{side}_{b}"]] - out[:, _I[f"{side}_{a}"]]
            ratio = np.linalg.norm(after, axis=-1) / np.linalg.norm(before, axis=-1)
            assert lo - 1e-9 <= ratio.min() and ratio.max() <= hi + 1e-9
            assert np.allclose(ratio, ratio[0])  # one factor for the whole stretch
            cos = np.sum(before * after, -1) / np.linalg.norm(before, axis=-1)
            assert np.allclose(cos / np.linalg.norm(after, axis=-1), 1.0)  # same direction
    # both sides scaled alike
    assert np.allclose(_length(out, "left_elbow", "left_wrist") / _length(joints, "left_elbow",
                       "left_wrist"), _length(out, "right_elbow", "right_wrist")
                       / _length(joints, "right_elbow", "right_wrist"))  # fmt: skip


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), frames=st.integers(20, 80), side=st.sampled_from(["left",
       "right"]))  # fmt: skip
def test_a_sampled_arm_keeps_its_lengths_and_the_anatomical_ranges(
    seed: int, frames: int, side: str
) -> None:
    rng = np.random.default_rng(seed)
    joints = _person(rng, frames)
    ranges = Ranges()
    out = sample_arm(joints, side, rng=rng, ranges=ranges)
    other = "right" if side == "left" else "left"
    moved = [_I[f"{side}_elbow"], _I[f"{side}_wrist"]]
    kept = [i for i in range(17) if i not in moved]
    assert np.allclose(out[:, kept], joints[:, kept])
    for a, b in (("shoulder", "elbow"), ("elbow", "wrist")):
        assert np.allclose(_length(out, f"{side}_{a}", f"{side}_{b}"),
                           np.median(_length(joints, f"{side}_{a}", f"{side}_{b}")))  # fmt: skip
    assert np.allclose(out[:, _I[f"{other}_wrist"]], joints[:, _I[f"{other}_wrist"]])
    s, e, w = (out[:, _I[f"{side}_{j}"]] for j in ("shoulder", "elbow", "wrist"))
    upper, fore = e - s, w - e
    cos = np.sum(upper * fore, -1) / (
        np.linalg.norm(upper, axis=-1) * np.linalg.norm(fore, axis=-1)
    )
    bend = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    assert bend.max() <= ranges.bend_deg[1] + 1e-6
    forward, left, up = torso_frame(out[:, _I["left_shoulder"]], out[:, _I["right_shoulder"]],
                                    mid_hip=out[:, TORSO[2:]].mean(axis=1))  # fmt: skip
    unit = upper / np.linalg.norm(upper, axis=-1, keepdims=True)
    raised = np.degrees(np.arccos(np.clip(-np.sum(unit * up, -1), -1, 1)))
    assert raised.max() <= ranges.raise_deg[1] + 1e-6
    outward = left if side == "left" else -left
    swing = np.degrees(np.arctan2(np.sum(unit * forward, -1), np.sum(unit * outward, -1)))
    lifted = raised > 5.0  # the swing of an arm hanging straight down is undefined
    assert (swing[lifted] >= ranges.swing_deg[0] - 1e-6).all()
    assert (swing[lifted] <= ranges.swing_deg[1] + 1e-6).all()
