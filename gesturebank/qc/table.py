"""The one table of QC checks (issue 42): what each absolute check reads, its threshold, unit,
whether it judges a stretch or the whole take, and how the dashboard names it.

Config (`config.QCConfig` holds each `field`; a test keeps the two in step), the verdicts
(`qc.checks`), the stretch cutting (`qc.stretches`), re-judging (`datasets.refresh`) and the
dashboard (`report.render`) all read `CHECKS`. Adding a check is one `Check` here (or a call to
`register` from a plug-in) plus its metric function; docs/architecture.md walks through one.

- scope "stretch": the fault lies in some stretch of the clip (sideways, frozen at a limit, a
  glitch, no speech...): the clip is cut around the failing stretch (`qc.stretches`) and the
  pieces are judged again. `stretch` gives the per-frame signal the cut follows.
- scope "take": the fault is the whole clip's (a still picture, bones drifting, audio that does
  not match): the clip is rejected whole.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from gesturebank.config import QCConfig
from gesturebank.qc.clip_metrics import ClipMetrics, number

if TYPE_CHECKING:
    from gesturebank.clip import Clip
    from gesturebank.robot.pepper import RobotProfile

Scope = Literal["stretch", "take"]
Side = Literal["max", "min"]
# How the dashboard writes a unit: (format of the scaled value, scale).
UNITS: dict[str, tuple[str, float]] = {
    "share": ("{:.0f} %", 100.0),
    "s": ("{:.1f} s", 1.0),
    "rad": ("{:.1f}°", math.degrees(1.0)),
    "cm": ("{:.1f} cm", 1.0),
    "count": ("{:.0f}", 1.0),
    "shoulder widths": ("{:.2f} shoulder widths", 1.0),
    "share of the frame height": ("{:.1f} % of the frame height", 100.0),
    "rad²/s⁵": ("{:.3g} rad²/s⁵", 1.0),
    "people": ("{:.1f}", 1.0),
    "HSV change": ("{:.3f}", 1.0),
}


@dataclass(frozen=True)
class Signal:
    """A stretch check's per-video-frame signal over one clip (`qc.stretches` cuts by it):
    `values (T,)`, `weights (T,)` (0: the frame does not count), and the `limit` their weighted
    mean must not exceed (an aggregate: a share of frames, a mean), or with `events` that each
    frame's value must not exceed (a spike, the part of a frozen run beyond the limit)."""

    values: np.ndarray
    weights: np.ndarray
    limit: float
    events: bool = False


# A reason: the metric's value, the limit, the clip's metrics and the config → one line of text.
Reason = Callable[[float, float, ClipMetrics, QCConfig], str]
# A stretch check's per-frame signal over one clip.
StretchSignal = Callable[["Clip", QCConfig, "RobotProfile"], Signal]
# A check's own metric, for a check whose metric is no ClipMetrics field (a plug-in's).
Measure = Callable[["Clip", QCConfig, "RobotProfile"], float]


@dataclass(frozen=True)
class Check:
    """One absolute QC check.

    name: short id (in the docs and tests); metric: the `ClipMetrics` field (or a plug-in's
    metric, measured by `measure`); field: the `QCConfig` field holding the limit (None there:
    not judged); side: "max" (fails above) or "min" (fails below); unit: a key of `UNITS`;
    scope: "stretch" or "take" (module docstring); label: the dashboard's name of the metric;
    reason: the reason's text (`str.format` of v, lim, m: the metrics, c: the config, or a
    function of the same); stretch: the per-frame signal a stretch check cuts by (a built-in
    one's is `qc.stretches.SIGNALS[name]`, which the table does not import).
    """

    name: str
    metric: str
    field: str | None
    side: Side
    unit: str
    scope: Scope
    label: str
    reason: str | Reason
    stretch: StretchSignal | None = None
    measure: Measure | None = None

    def limit(self, config: QCConfig) -> float | None:
        """The check's limit under `config`; None when the check is off."""
        if self.field is not None and not hasattr(config, self.field):
            raise KeyError(f"QC check {self.name!r}: no qc setting {self.field!r}")
        value = None if self.field is None else getattr(config, self.field)
        return None if value is None else float(value)

    def fails(self, value: float | None, config: QCConfig) -> bool:
        """Whether `value` fails the check (NaN and None fail nothing, as an off check)."""
        limit = self.limit(config)
        v = number(value)
        if limit is None or not math.isfinite(v):
            return False
        return v > limit if self.side == "max" else v < limit

    def text(self, value: float, metrics: ClipMetrics, config: QCConfig) -> str:
        """The reason of a failure at `value`."""
        limit = self.limit(config)
        lim = math.nan if limit is None else limit
        if callable(self.reason):
            return self.reason(value, lim, metrics, config)
        return self.reason.format(v=value, lim=lim, m=metrics, c=config)


def _frozen_reason(value: float, limit: float, m: ClipMetrics, c: QCConfig) -> str:
    return (
        f"robot frozen at a limit: {m.frozen_joint} held within {c.frozen_limit_tol:g} rad of its "
        f"limit for {value:.1f} s while the person's angle moves more than "
        f"{c.frozen_min_motion:g} rad in {c.frozen_motion_window_s:g} s (max {limit:g} s)"
    )


def _static_reason(value: float, limit: float, m: ClipMetrics, c: QCConfig) -> str:
    return (
        f"static: no joint moves more than {math.degrees(value):.1f}° "
        f"(min {math.degrees(limit):.1f}°)"
    )


def _check(
    name: str,
    metric: str,
    field: str | None,
    side: Side,
    unit: str,
    scope: Scope,
    label: str,
    reason: str | Reason,
) -> Check:
    """A built-in check; a stretch check's signal is `qc.stretches.SIGNALS[name]`."""
    return Check(name, metric, field, side, unit, scope, label, reason)


# In the order the reasons are written (the order before the table, so records compare equal).
CHECKS: list[Check] = [
    _check(
        "head_unseen",
        "head_unknown_fraction",
        "max_head_unknown_fraction",
        "max",
        "share",
        "stretch",
        "head unseen",
        "head unseen in {v:.0%} of the clip (max {lim:.0%})",
    ),
    _check(
        "arms_unseen",
        "arms_unknown_fraction",
        "max_arms_unknown_fraction",
        "max",
        "share",
        "stretch",
        "both arms unseen",
        "both arms unseen in {v:.0%} of the clip (max {lim:.0%})",
    ),
    _check(
        "bones_drift",
        "bone_cv_max",
        "max_bone_cv",
        "max",
        "share",
        "take",
        "bone length variation",
        "3D bone length varies by {v:.0%} (max {lim:.0%})",
    ),
    _check(
        "beyond_reach",
        "out_of_reach_fraction",
        "max_limit_fraction",
        "max",
        "share",
        "stretch",
        "beyond reach",
        "a joint beyond the robot's reach in {v:.0%} of frames (max {lim:.0%})",
    ),
    _check(
        "frozen_at_limit",
        "frozen_at_limit_s",
        "max_frozen_at_limit_s",
        "max",
        "s",
        "stretch",
        "frozen at a limit",
        _frozen_reason,
    ),
    _check(
        "jitter",
        "jitter_fraction",
        "max_jitter_fraction",
        "max",
        "share",
        "stretch",
        "raw power above the jitter band",
        "jitter: {v:.0%} of raw motion power above {c.jitter_above_hz:g} Hz (max {lim:.0%})",
    ),
    _check(
        "swaps",
        "swap_events",
        "max_swap_events",
        "max",
        "count",
        "stretch",
        "left/right swaps",
        "left/right arms swapped {v:.0f}× (max {lim:.0f})",
    ),
    _check(
        "spike",
        "spike_max",
        "max_spike",
        "max",
        "shoulder widths",
        "stretch",
        "largest spike",
        "keypoint jumps {v:.2f} shoulder widths in one frame (max {lim:g})",
    ),
    _check(
        "frozen_pose",
        "frozen_fraction",
        "max_frozen_fraction",
        "max",
        "share",
        "take",
        "frozen pose",
        "pose frozen (exactly repeated) in {v:.0%} of frames (max {lim:.0%})",
    ),
    _check(
        "static",
        "motion_range",
        "min_motion_range",
        "min",
        "rad",
        "take",
        "motion range",
        _static_reason,
    ),
    _check(
        "facing_away",
        "facing_away_fraction",
        "max_facing_away_fraction",
        "max",
        "share",
        "stretch",
        "facing away",
        "facing away in {v:.0%} of frames (max {lim:.0%})",
    ),
    _check(
        "sideways",
        "sideways_fraction",
        "max_sideways_fraction",
        "max",
        "share",
        "stretch",
        "seen from the side",
        "seen from the side in {v:.0%} of frames (max {lim:.0%})",
    ),
    _check(
        "too_small",
        "shoulder_width",
        "min_shoulder_width",
        "min",
        "share of the frame height",
        "take",
        "shoulder width",
        "too small: shoulders {v:.1%} of the frame height (min {lim:.1%})",
    ),
    _check(
        "still_picture",
        "image_change",
        "min_image_change",
        "min",
        "HSV change",
        "take",
        "image change",
        "still picture: image change {v:.3f} (min {lim:g})",
    ),
    _check(
        "crowd",
        "people",
        "max_people",
        "max",
        "people",
        "take",
        "people in the frame",
        "too many people: {v:.1f} on average (max {lim:g})",
    ),
    _check(
        "no_speech",
        "speech_fraction",
        "min_speech_fraction",
        "min",
        "share",
        "stretch",
        "speech heard",
        "no speech: speech heard in {v:.0%} of the clip (min {lim:.0%})",
    ),
    _check(
        "depth_uncertain",
        "expected_hand_error_cm",
        "max_expected_hand_error_cm",
        "max",
        "cm",
        "stretch",
        "expected hand error",
        "depth uncertain: expected hand error {v:.1f} cm (depth confidence "
        "{m.depth_confidence:.2f}; max {lim:g} cm)",
    ),
    _check(
        "audio_mismatch",
        "trimmed_fraction",
        "max_trimmed_fraction",
        "max",
        "share",
        "take",
        "take's video outside its audio",
        "audio and video overlap in part: trimming to their common span drops {v:.0%} of the "
        "take's video (max {lim:.0%})",
    ),
    _check(
        "raw_jerk",
        "jerk_raw",
        "max_jerk_raw",
        "max",
        "rad²/s⁵",
        "take",
        "raw jerk",
        "raw jerk {v:.3g} rad²/s⁵ (max {lim:.3g})",
    ),
]


def register(check: Check) -> None:
    """Add a check (a plug-in's) to the table, or replace the one of the same name. Its `field`
    is a setting of the `QCConfig` it is judged with (a plug-in's config may extend it)."""
    if check.scope == "stretch" and check.stretch is None:
        raise ValueError(f"check {check.name!r}: a stretch check needs its stretch signal")
    if check.scope == "take" and check.stretch is not None:
        raise ValueError(f"check {check.name!r}: a whole-take check has no stretch signal")
    unregister(check.name)
    CHECKS.append(check)


def unregister(name: str) -> None:
    """Remove check `name` from the table (nothing when it is not there)."""
    CHECKS[:] = [c for c in CHECKS if c.name != name]


def by_metric(metric: str) -> Check | None:
    """The check on `metric`, None when it has none."""
    return next((c for c in CHECKS if c.metric == metric), None)


def by_name(name: str) -> Check:
    """The check `name` (KeyError naming the known ones)."""
    for c in CHECKS:
        if c.name == name:
            return c
    raise KeyError(f"no QC check {name!r}; known: {', '.join(c.name for c in CHECKS)}")
