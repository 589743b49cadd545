"""QC verdicts: absolute thresholds on each clip's metrics plus dataset-relative outliers.

Pure functions over metrics (`qc.clip_metrics.ClipMetrics`). A clip is `rejected` when any
check fails; each failed check adds one reason with its numbers (degrees and seconds in the
text). Rejected clips stay in the dataset, flagged, so they can be looked at (the dashboard,
`report`) and re-admitted by changing the thresholds.

What is stored is judged as well as what was measured: the processed angles' steps (the speed
invariant, `qc.invariants`), their jerk (the jerk invariant and the relative check on `jerk`)
and a robot frozen at a limit while the person moves (`frozen_at_limit_s`). Motion beyond the
robot's reach is reported, not judged, unless `max_limit_fraction` is set.

Relative check (as Fig. 4.7, where one subject's failed 3D pose stands out): for each of
`outlier_metrics` the robust z-score of log(metric) over the dataset's clips,
z = (log m − median) / (1.4826 · MAD). A clip is an outlier when z > `outlier_z` and its metric is
also more than `outlier_min_ratio` × the dataset median (so a dataset of near-identical clips
with a tiny MAD does not reject ordinary variation). Needs `outlier_min_clips` clips.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Literal

import numpy as np

from gesturebank.config import QCConfig
from gesturebank.qc.clip_metrics import ClipMetrics, number
from gesturebank.qc.invariants import invariant_reasons
from gesturebank.robot.pepper import JOINTS

Verdict = tuple[Literal["accepted", "rejected"], list[str]]


# A clip whose head and both arms were each unseen too long (clips.max_part_unseen_fraction):
# every part masked (issue 32: parts are judged on their own, the clip keeps those seen).
NO_PART = (
    "no body part seen: head, left arm and right arm each unseen in more than "
    "clips.max_part_unseen_fraction of the clip"
)

LABELS = {"jerk_raw": "raw jerk", "jerk": "processed jerk"}  # in the outlier reasons

# The absolute checks as `absolute_reasons` applies them: metric → (QCConfig field, "max" | "min").
# The dashboard shows each metric beside its threshold from this table (a test keeps the two in
# step); a field that is None (max_jerk_raw by default) is no check.
THRESHOLDS: dict[str, tuple[str, Literal["max", "min"]]] = {
    "head_unknown_fraction": ("max_head_unknown_fraction", "max"),
    "arms_unknown_fraction": ("max_arms_unknown_fraction", "max"),
    "bone_cv_max": ("max_bone_cv", "max"),
    "out_of_reach_fraction": ("max_limit_fraction", "max"),  # opt-in (None: reported only)
    "frozen_at_limit_s": ("max_frozen_at_limit_s", "max"),
    "jitter_fraction": ("max_jitter_fraction", "max"),
    "swap_events": ("max_swap_events", "max"),
    "spike_max": ("max_spike", "max"),
    "frozen_fraction": ("max_frozen_fraction", "max"),
    "motion_range": ("min_motion_range", "min"),
    "facing_away_fraction": ("max_facing_away_fraction", "max"),
    "sideways_fraction": ("max_sideways_fraction", "max"),
    "shoulder_width": ("min_shoulder_width", "min"),
    "image_change": ("min_image_change", "min"),
    "people": ("max_people", "max"),
    "speech_fraction": ("min_speech_fraction", "min"),
    "expected_hand_error_cm": ("max_expected_hand_error_cm", "max"),
    "trimmed_fraction": ("max_trimmed_fraction", "max"),
    "jerk_raw": ("max_jerk_raw", "max"),
}


def threshold(key: str, config: QCConfig) -> tuple[Literal["max", "min"], float] | None:
    """("max" | "min", limit) of the absolute check on metric `key`; None when it has none."""
    if key not in THRESHOLDS:
        return None
    field, side = THRESHOLDS[key]
    limit = getattr(config, field)
    return None if limit is None else (side, float(limit))


def fails(key: str, value: float | None, config: QCConfig) -> bool:
    """Whether metric `key` at `value` fails its absolute check (NaN and None fail nothing)."""
    check = threshold(key, config)
    if check is None or value is None or not math.isfinite(value):
        return False
    side, limit = check
    return value > limit if side == "max" else value < limit


def is_outlier_reason(key: str, reason: str) -> bool:
    """Whether `reason` is the dataset-relative outlier reason of metric `key`."""
    return reason.startswith(f"{LABELS.get(key, key)} ") and "× dataset median" in reason


def absolute_reasons(metrics: ClipMetrics, config: QCConfig) -> list[str]:
    """Reasons (empty when none) of the absolute checks on one clip's metrics; NaN metrics are
    not measured and fail nothing."""
    c = config
    m = metrics
    reasons = []

    def over(value: float | None, limit: float, text: str) -> None:
        if number(value) > limit:
            reasons.append(text.format(v=value, lim=limit))

    def under(value: float | None, limit: float, text: str) -> None:
        if number(value) < limit:
            reasons.append(text.format(v=value, lim=limit))

    if c.max_head_unknown_fraction is not None:  # opt-in: judged by part by default
        over(
            m.head_unknown_fraction,
            c.max_head_unknown_fraction,
            "head unseen in {v:.0%} of the clip (max {lim:.0%})",
        )
    if c.max_arms_unknown_fraction is not None:
        over(
            m.arms_unknown_fraction,
            c.max_arms_unknown_fraction,
            "both arms unseen in {v:.0%} of the clip (max {lim:.0%})",
        )
    parts = (m.head_unknown_fraction, m.left_arm_unknown_fraction, m.right_arm_unknown_fraction)
    if all(number(p) >= 1.0 for p in parts):  # every part masked: nothing left to learn from
        reasons.append(NO_PART)
    over(m.bone_cv_max, c.max_bone_cv, "3D bone length varies by {v:.0%} (max {lim:.0%})")
    if c.max_limit_fraction is not None:  # opt-in: reach is reported, not judged, by default
        over(
            m.out_of_reach_fraction,
            c.max_limit_fraction,
            "a joint beyond the robot's reach in {v:.0%} of frames (max {lim:.0%})",
        )
    if m.frozen_at_limit_s > (c.max_frozen_at_limit_s or math.inf):
        # a joint not measured (NaN) is never the one named
        frozen = {
            j: s if math.isfinite(s) else -1.0
            for j, s in zip(JOINTS, m.frozen_at_limit_s_per_joint, strict=True)
        }
        joint = max(JOINTS, key=lambda j: frozen[j])
        reasons.append(
            f"robot frozen at a limit: {joint} held within {c.frozen_limit_tol:g} rad of its "
            f"limit for {m.frozen_at_limit_s:.1f} s while the person's angle moves more than "
            f"{c.frozen_min_motion:g} rad (max {c.max_frozen_at_limit_s:g} s)"
        )
    over(
        m.jitter_fraction,
        c.max_jitter_fraction,
        f"jitter: {{v:.0%}} of raw motion power above {c.jitter_above_hz:g} Hz (max {{lim:.0%}})",
    )
    over(m.swap_events, c.max_swap_events, "left/right arms swapped {v:.0f}× (max {lim:.0f})")
    over(
        m.spike_max, c.max_spike, "keypoint jumps {v:.2f} shoulder widths in one frame (max {lim})"
    )
    over(
        m.frozen_fraction,
        c.max_frozen_fraction,
        "pose frozen (exactly repeated) in {v:.0%} of frames (max {lim:.0%})",
    )
    if m.motion_range < c.min_motion_range:
        reasons.append(
            f"static: no joint moves more than {np.degrees(m.motion_range):.1f}° "
            f"(min {np.degrees(c.min_motion_range):.1f}°)"
        )
    over(
        m.facing_away_fraction,
        c.max_facing_away_fraction,
        "facing away in {v:.0%} of frames (max {lim:.0%})",
    )
    over(
        m.sideways_fraction,
        c.max_sideways_fraction,
        "seen from the side in {v:.0%} of frames (max {lim:.0%})",
    )
    under(
        m.shoulder_width,
        c.min_shoulder_width,
        "too small: shoulders {v:.1%} of the frame height (min {lim:.1%})",
    )
    under(m.image_change, c.min_image_change, "still picture: image change {v:.3f} (min {lim:g})")
    over(m.people, c.max_people, "too many people: {v:.1f} on average (max {lim:g})")
    if c.min_speech_fraction is not None:
        under(
            m.speech_fraction,
            c.min_speech_fraction,
            "no speech: speech heard in {v:.0%} of the clip (min {lim:.0%})",
        )
    if c.max_expected_hand_error_cm is not None:
        over(
            m.expected_hand_error_cm,
            c.max_expected_hand_error_cm,
            "depth uncertain: expected hand error {v:.1f} cm (depth confidence "
            f"{m.depth_confidence:.2f}; max {{lim:g}} cm)",
        )
    over(
        m.trimmed_fraction,
        c.max_trimmed_fraction,
        "audio and video overlap in part: trimming to their common span drops {v:.0%} of the "
        "take's video (max {lim:.0%})",
    )
    if c.max_jerk_raw is not None:
        over(m.jerk_raw, c.max_jerk_raw, "raw jerk {v:.3g} rad²/s⁵ (max {lim:.3g})")
    return reasons + invariant_reasons(m.invariants, c)


def robust_z(values: np.ndarray) -> tuple[np.ndarray, float]:
    """Robust z-scores `(n,)` of `values (n,)` (median / 1.4826·MAD; NaN stays NaN) and the
    median. With MAD = 0 the z-score is ±inf off the median and 0 on it."""
    v = np.asarray(values, dtype=np.float64)
    finite = v[np.isfinite(v)]
    if not len(finite):
        return np.full_like(v, np.nan), math.nan
    med = float(np.median(finite))
    mad = 1.4826 * float(np.median(np.abs(finite - med)))
    with np.errstate(divide="ignore", invalid="ignore"):
        z = (v - med) / mad if mad > 0 else np.where(v == med, 0.0, np.sign(v - med) * np.inf)
    return z, med


def relative_reasons(
    metrics_by_clip: Mapping[str, ClipMetrics], config: QCConfig
) -> dict[str, list[str]]:
    """Dataset-relative outlier reasons per clip id (see the module docstring)."""
    ids = list(metrics_by_clip)
    out: dict[str, list[str]] = {i: [] for i in ids}
    if len(ids) < config.outlier_min_clips:
        return out
    for key in config.outlier_metrics:
        values = np.array([metrics_by_clip[i].value(key) for i in ids])
        with np.errstate(divide="ignore", invalid="ignore"):
            logs = np.where(values > 0, np.log(values), np.nan)
        z, med_log = robust_z(logs)
        if not np.isfinite(med_log):
            continue
        ratio = values / math.exp(med_log)
        for i, zi, ri in zip(ids, z, ratio, strict=True):
            if zi > config.outlier_z and ri > config.outlier_min_ratio:
                label = LABELS.get(key, key)
                out[i].append(f"{label} {ri:.1f}× dataset median (robust z {zi:.1f})")
    return out


def verdicts(
    metrics_by_clip: Mapping[str, ClipMetrics], config: QCConfig | None = None
) -> dict[str, Verdict]:
    """(status, reasons) per clip id: "rejected" with every failed check's reason, else
    "accepted". `metrics_by_clip` holds the clips of one dataset."""
    c = config or QCConfig()
    relative = relative_reasons(metrics_by_clip, c)
    result: dict[str, Verdict] = {}
    for clip_id, metrics in metrics_by_clip.items():
        reasons = absolute_reasons(metrics, c) + relative[clip_id]
        result[clip_id] = ("rejected" if reasons else "accepted", reasons)
    return result
