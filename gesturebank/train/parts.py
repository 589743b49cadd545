"""The body parts a model's training and test clips must have (issue 32: clips are judged by
part, so a dataset holds head-only and arms-only clips beside whole ones).

A model predicts `target_joints` (a model class may name fewer than Pepper's 11 joints with a
`target_joints` class attribute). By default its clips need every part whose joints it predicts,
unless it predicts every part: a model of the whole body learns from every clip, each joint's
loss masked where the joint is unknown (`datasets.torch.masked_mse`). So an arm model never
trains on head-only clips, and a head model uses them.
"""

from __future__ import annotations

from collections.abc import Sequence

from gesturebank.clip import PART_JOINTS, PARTS, parts_label
from gesturebank.robot.pepper import JOINTS


def target_joints(model_class: object) -> tuple[str, ...]:
    """The joints a model class predicts: its `target_joints`, else all of `pepper.JOINTS`."""
    return tuple(getattr(model_class, "target_joints", JOINTS))


def default_require(targets: Sequence[str]) -> str | None:
    """The parts label every clip must have for a model predicting `targets` (joint names):
    the parts any target belongs to, or None (every clip) when that is every part."""
    parts = {p for p in PARTS if set(PART_JOINTS[p]) & set(targets)}
    return None if parts == set(PARTS) else parts_label(parts)
