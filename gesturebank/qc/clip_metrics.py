"""`ClipMetrics`: what the QC measured of one clip (`qc.metrics.clip_metrics`), the type the
checks (`qc.checks`) judge and `qc.outlier_metrics` names.

On disk (a take record's and the manifest's `metrics`) the metrics are a flat mapping of names to
numbers: `to_dict` writes it, keys in a fixed order, and `from_dict` reads it back, a number that
is missing (a clip measured by an older gesturebank) as NaN, so it fails no check.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields

from gesturebank.qc.invariants import InvariantMetrics
from gesturebank.robot.pepper import JOINTS

_NAN = math.nan


def number(value: float | None) -> float:
    """A stored metric as a float: None (not measured) is NaN."""
    return float(value) if value is not None else _NAN


@dataclass(frozen=True)
class ClipMetrics:
    """The QC metrics of one clip, plain floats (NaN where a metric has nothing to measure).

    duration_s:            seconds of the 100 Hz clock
    jerk_raw, jerk:        J (Eq. 3.21) of the raw and the processed angles, summed over the
                           joints; per joint (in `pepper.JOINTS` order) `*_per_joint`
    head_unknown_fraction, arms_unknown_fraction: shares of the 100 Hz clock unseen (both arms)
    left_arm_unknown_fraction, right_arm_unknown_fraction: each arm's (a part masked whole: 1)
    torso_gap_s:           longest stretch with a shoulder unseen
    bone_cv_max:           largest variation of a 3D bone's length (std / mean)
    swap_events, frozen_fraction, spike_max (shoulder widths): of the keypoints' motion
    out_of_reach_fraction, out_of_reach_per_joint, frozen_at_limit_s(_per_joint): the
                           robot's reach (`qc.metrics.reach_metrics`)
    invariants:            `qc.invariants.InvariantMetrics`
    jitter_fraction, motion_range (rad), facing_away_fraction, sideways_fraction,
    shoulder_width (share of the frame height), image_change, people (mean in the frame)
    speech_fraction:       share of the 100 Hz clock with speech heard (`Clip.speech`)
    depth_confidence:      mean of `Clip.depth_confidence` over the video frames
    expected_hand_error_cm: the Pepper hand error that confidence meant on the renders
                           (`lift.depth_confidence.expected_hand_error_cm`; NaN: no calibration
                           for the clip's lifter)
    trimmed_fraction:      of the whole take the clip is cut from (set by the build; None when
                           the clip alone was measured)
    extra:                 metrics of checks added to `qc.table` (a plug-in's), by name
    """

    duration_s: float
    jerk_raw: float
    jerk: float
    jerk_raw_per_joint: tuple[float, ...]
    jerk_per_joint: tuple[float, ...]
    head_unknown_fraction: float
    arms_unknown_fraction: float
    left_arm_unknown_fraction: float
    right_arm_unknown_fraction: float
    torso_gap_s: float
    bone_cv_max: float
    swap_events: float
    frozen_fraction: float
    spike_max: float
    out_of_reach_fraction: float
    out_of_reach_per_joint: tuple[float, ...]
    frozen_at_limit_s_per_joint: tuple[float, ...]
    frozen_at_limit_s: float
    invariants: InvariantMetrics
    jitter_fraction: float
    motion_range: float
    facing_away_fraction: float
    sideways_fraction: float
    shoulder_width: float
    image_change: float
    people: float
    speech_fraction: float
    depth_confidence: float
    expected_hand_error_cm: float
    trimmed_fraction: float | None = None
    extra: Mapping[str, float] = field(default_factory=dict)

    def value(self, name: str) -> float:
        """The single-number metric `name` (one of `METRIC_NAMES`, or an `extra` one), NaN when
        not measured."""
        if name in self.extra:
            return number(self.extra[name])
        if name not in METRIC_NAMES:
            raise KeyError(f"no single-number clip metric {name!r}")
        return number(getattr(self, name))

    @property
    def frozen_joint(self) -> str:
        """The joint held longest at a limit (a joint not measured, NaN, is never the one)."""
        held = [s if math.isfinite(s) else -1.0 for s in self.frozen_at_limit_s_per_joint]
        return JOINTS[max(range(len(JOINTS)), key=lambda j: held[j])]

    def to_dict(self) -> dict[str, float]:
        """The flat mapping stored on disk: `jerk_raw/<Joint>`, `jerk/<Joint>`,
        `out_of_reach/<Joint>`, `frozen_at_limit_s/<Joint>` for the per-joint values,
        `invariant/<name>` for the invariants; trimmed_fraction only when measured."""
        m: dict[str, float] = {
            "duration_s": self.duration_s,
            "jerk_raw": self.jerk_raw,
            "jerk": self.jerk,
        }
        for name, jr, jp in zip(JOINTS, self.jerk_raw_per_joint, self.jerk_per_joint, strict=True):
            m[f"jerk_raw/{name}"] = jr
            m[f"jerk/{name}"] = jp
        m["head_unknown_fraction"] = self.head_unknown_fraction
        m["arms_unknown_fraction"] = self.arms_unknown_fraction
        m["left_arm_unknown_fraction"] = self.left_arm_unknown_fraction
        m["right_arm_unknown_fraction"] = self.right_arm_unknown_fraction
        m["torso_gap_s"] = self.torso_gap_s
        m["bone_cv_max"] = self.bone_cv_max
        m["swap_events"] = self.swap_events
        m["frozen_fraction"] = self.frozen_fraction
        m["spike_max"] = self.spike_max
        m["out_of_reach_fraction"] = self.out_of_reach_fraction
        reach = zip(
            JOINTS, self.out_of_reach_per_joint, self.frozen_at_limit_s_per_joint, strict=True
        )
        for name, beyond, frozen in reach:
            m[f"out_of_reach/{name}"] = beyond
            m[f"frozen_at_limit_s/{name}"] = frozen
        m["frozen_at_limit_s"] = self.frozen_at_limit_s
        m.update(self.invariants.to_dict())
        m["jitter_fraction"] = self.jitter_fraction
        m["motion_range"] = self.motion_range
        m["facing_away_fraction"] = self.facing_away_fraction
        m["sideways_fraction"] = self.sideways_fraction
        m["shoulder_width"] = self.shoulder_width
        m["image_change"] = self.image_change
        m["people"] = self.people
        m["speech_fraction"] = self.speech_fraction
        m["depth_confidence"] = self.depth_confidence
        m["expected_hand_error_cm"] = self.expected_hand_error_cm
        if self.trimmed_fraction is not None:
            m["trimmed_fraction"] = self.trimmed_fraction
        m.update(self.extra)
        return m

    @classmethod
    def from_dict(cls, metrics: Mapping[str, float | None]) -> ClipMetrics:
        """The metrics stored as `to_dict` writes them; a missing or None number is NaN (None
        for trimmed_fraction and the invariants' optional numbers), other keys are ignored."""

        def get(key: str) -> float:
            return number(metrics.get(key))

        def per_joint(prefix: str) -> tuple[float, ...]:
            return tuple(get(f"{prefix}/{name}") for name in JOINTS)

        trimmed = metrics.get("trimmed_fraction")
        return cls(
            duration_s=get("duration_s"),
            jerk_raw=get("jerk_raw"),
            jerk=get("jerk"),
            jerk_raw_per_joint=per_joint("jerk_raw"),
            jerk_per_joint=per_joint("jerk"),
            head_unknown_fraction=get("head_unknown_fraction"),
            arms_unknown_fraction=get("arms_unknown_fraction"),
            left_arm_unknown_fraction=get("left_arm_unknown_fraction"),
            right_arm_unknown_fraction=get("right_arm_unknown_fraction"),
            torso_gap_s=get("torso_gap_s"),
            bone_cv_max=get("bone_cv_max"),
            swap_events=get("swap_events"),
            frozen_fraction=get("frozen_fraction"),
            spike_max=get("spike_max"),
            out_of_reach_fraction=get("out_of_reach_fraction"),
            out_of_reach_per_joint=per_joint("out_of_reach"),
            frozen_at_limit_s_per_joint=per_joint("frozen_at_limit_s"),
            frozen_at_limit_s=get("frozen_at_limit_s"),
            invariants=InvariantMetrics.from_dict(metrics),
            jitter_fraction=get("jitter_fraction"),
            motion_range=get("motion_range"),
            facing_away_fraction=get("facing_away_fraction"),
            sideways_fraction=get("sideways_fraction"),
            shoulder_width=get("shoulder_width"),
            image_change=get("image_change"),
            people=get("people"),
            speech_fraction=get("speech_fraction"),
            depth_confidence=get("depth_confidence"),
            expected_hand_error_cm=get("expected_hand_error_cm"),
            trimmed_fraction=None if trimmed is None else float(trimmed),
            extra={
                k: number(v) for k, v in metrics.items() if "/" not in k and k not in _FIELD_NAMES
            },  # a plug-in check's metric, stored beside the others
        )


# The single-number metrics, by field name: what a check or `qc.outlier_metrics` can name
# (config.MetricName lists the same names; a test keeps the two equal).
METRIC_NAMES = tuple(f.name for f in fields(ClipMetrics) if f.type in ("float", "float | None"))
_FIELD_NAMES = frozenset(f.name for f in fields(ClipMetrics))
