"""The 2D scores of a detection against a render's truth, on hand-made points."""

from __future__ import annotations

import numpy as np
import pytest

from gesturebank.skeletons import COCO17
from gesturebank.synth.score import UPPER, score_2d, worst_joint_p90

IDX = COCO17.index


def _truth(frames: int = 10) -> np.ndarray:
    """(T, 17, 2) px: a person whose mid-shoulder to mid-hip (torso) is 100 px."""
    xy = np.zeros((frames, len(COCO17), 2))
    for side, x in (("left", 60.0), ("right", 40.0)):
        xy[:, IDX[f"{side}_shoulder"]] = (x, 100)
        xy[:, IDX[f"{side}_elbow"]] = (x + (10 if side == "left" else -10), 150)
        xy[:, IDX[f"{side}_wrist"]] = (x + (20 if side == "left" else -20), 190)
        xy[:, IDX[f"{side}_hip"]] = (x, 200)
        xy[:, IDX[f"{side}_knee"]] = (x, 280)
        xy[:, IDX[f"{side}_ankle"]] = (x, 360)
    return xy


def test_worst_joint_p90_is_the_worst_joints_90th_percentile_in_torso_lengths() -> None:
    truth = _truth()
    detected = truth.copy()
    # the left wrist off by 0, 10, …, 90 px over the ten frames: its 90th percentile (the
    # smallest error 9 of the 10 frames do not exceed) is 80 px = 80 % of the torso; the right
    # elbow is off 30 px in every frame
    detected[:, IDX["left_wrist"], 0] += np.arange(10) * 10.0
    detected[:, IDX["right_elbow"], 1] += 30.0
    assert worst_joint_p90(detected, truth) == pytest.approx(80.0)


def test_a_lost_joint_counts_as_infinitely_far() -> None:
    truth = _truth()
    detected = truth.copy()
    detected[:2, IDX["right_hip"]] = np.nan  # lost in 2 of 10 frames: past the 90th percentile
    assert worst_joint_p90(detected, truth) == np.inf
    detected = truth.copy()
    detected[:1, IDX["right_hip"]] = np.nan  # in 1 of 10: the 90th percentile still holds
    assert worst_joint_p90(detected, truth) == pytest.approx(0.0)


def test_legs_do_not_count() -> None:
    truth = _truth()
    detected = truth.copy()
    detected[:, IDX["left_ankle"]] += 500.0
    assert IDX["left_ankle"] not in UPPER
    assert worst_joint_p90(detected, truth) == pytest.approx(0.0)


def test_exchanged_frames_are_counted() -> None:
    truth = _truth()
    detected = truth.copy()
    left = [IDX[f"left_{j}"] for j in ("shoulder", "elbow", "wrist", "hip", "knee")]
    right = [IDX[f"right_{j}"] for j in ("shoulder", "elbow", "wrist", "hip", "knee")]
    detected[3:5, left + right] = truth[3:5, right + left]
    assert score_2d(detected, truth).swapped == pytest.approx(0.2)
