"""Invariants every written clip must hold, measured where the builder writes it (and again by
`gesturebank qc`), as metrics so that every later re-judging keeps them:

- speed: no processed angle steps between two samples more than `qc.max_speed_factor` × the
  robot profile's joint speed allows (a jump across a joint's range breaks it);
- jerk: the processed jerk (Eq. 3.21) is not above the raw jerk: processing never adds motion;
- mask: the processed angles are finite exactly where `mask` is true;
- limits: the processed angles lie inside the profile's limits;
- angles01: `angles01` is `angles` normalised (Eq. 3.13–3.14);
- audio: the audio features are finite and as many frames as the angles.

Each is a field of `InvariantMetrics`, stored as `invariant/<name>` (−1 = holds, else the first
frame that breaks it; speed, jerk: the worst one) with the numbers its reason quotes (no NaN, so
that two builds compare equal); `invariant_reasons` turns them into one reason each that names
the invariant and the frame.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields

import numpy as np

from gesturebank.clip import Clip
from gesturebank.config import QCConfig
from gesturebank.robot.pepper import JOINTS, RobotProfile, normalise

_ANGLES01_TOL = 1e-4  # float32 rounding of (θ − lower) / (upper − lower)
# Jerk (Eq. 3.21) of float32 rounding alone: Δ³θ ~ 3e-7 rad gives ½·100⁵·(3e-7)² ≈ 5e-4 rad² s⁻⁵
# at 100 Hz, while a person's clips measure 1e2–1e9: below this, "more jerk" is rounding noise.
_JERK_NOISE = 1e-2
_NAN = math.nan


HOLDS = -1.0


@dataclass(frozen=True)
class InvariantMetrics:
    """The invariants of one clip, stored as `invariant/<field>` (module docstring).

    speed, jerk, mask, limits, angles01, audio: HOLDS, else the first frame that breaks it (speed,
    jerk: the worst one); NaN for a clip measured before the invariants existed. The numbers the
    reasons quote, None where there is none: speed_ratio (largest step × the joint speed),
    speed_joint (its joint, when broken), jerk_ratio (processed / raw J), limits_joint (the
    first joint outside), audio_frames and angle_frames.
    """

    speed: float = HOLDS
    jerk: float = HOLDS
    mask: float = HOLDS
    limits: float = HOLDS
    angles01: float = HOLDS
    audio: float = HOLDS
    speed_ratio: float | None = None
    speed_joint: float | None = None
    jerk_ratio: float | None = None
    limits_joint: float | None = None
    audio_frames: float | None = None
    angle_frames: float | None = None

    def to_dict(self) -> dict[str, float]:
        """`invariant/<field>` → value, in field order, the numbers that are None left out."""
        out = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if value is not None:
                out[f"invariant/{f.name}"] = value
        return out

    @classmethod
    def from_dict(cls, metrics: Mapping[str, float | None]) -> InvariantMetrics:
        """The invariants among stored clip metrics (`to_dict` keys; others are ignored)."""

        def number(name: str) -> float | None:
            value = metrics.get(f"invariant/{name}")
            return None if value is None else float(value)

        def frame(name: str) -> float:  # missing: measured before the invariants existed
            value = number(name)
            return _NAN if value is None else value

        return cls(
            speed=frame("speed"),
            jerk=frame("jerk"),
            mask=frame("mask"),
            limits=frame("limits"),
            angles01=frame("angles01"),
            audio=frame("audio"),
            speed_ratio=number("speed_ratio"),
            speed_joint=number("speed_joint"),
            jerk_ratio=number("jerk_ratio"),
            limits_joint=number("limits_joint"),
            audio_frames=number("audio_frames"),
            angle_frames=number("angle_frames"),
        )


def _first(bad: np.ndarray) -> float:
    """Index of the first True frame of `bad (N, ...)`, HOLDS when none."""
    rows = np.flatnonzero(np.asarray(bad).reshape(len(bad), -1).any(axis=1))
    return float(rows[0]) if len(rows) else HOLDS


def invariant_metrics(
    clip: Clip, *, profile: RobotProfile, qc: QCConfig, jerk: float, jerk_raw: float
) -> InvariantMetrics:
    """The invariants of one clip as metrics (module docstring); `jerk`, `jerk_raw`: the clip's
    processed and raw J (`qc.metrics.clip_metrics`)."""
    a = np.asarray(clip.angles, dtype=np.float64)
    rate = 1.0 / float(np.median(np.diff(clip.times))) if len(clip.times) > 1 else 100.0
    m: dict[str, float] = {}  # the fields of InvariantMetrics that differ from its defaults

    steps = np.abs(np.diff(a, axis=0)) * rate / profile.velocity  # × the joint speed
    if np.isfinite(steps).any():
        frame, joint = np.unravel_index(np.nanargmax(steps), steps.shape)
        m["speed_ratio"] = float(steps[frame, joint])
        if steps[frame, joint] > qc.max_speed_factor:
            m["speed"] = float(frame + 1)
            m["speed_joint"] = float(joint)

    if jerk_raw > 0 and math.isfinite(jerk):
        m["jerk_ratio"] = jerk / jerk_raw
    if jerk > max(jerk_raw, _JERK_NOISE):  # NaN either side: not measured
        d3 = np.abs(a[3:] - 3 * a[2:-1] + 3 * a[1:-2] - a[:-3])
        if np.isfinite(d3).any():
            m["jerk"] = float(np.unravel_index(np.nanargmax(d3), d3.shape)[0] + 1)

    m["mask"] = _first(np.isfinite(a) != np.asarray(clip.mask, dtype=bool))

    with np.errstate(invalid="ignore"):
        outside = (a < profile.lower) | (a > profile.upper)
    m["limits"] = _first(outside)
    if outside.any():
        m["limits_joint"] = float(np.flatnonzero(outside[int(m["limits"])])[0])

    a01 = np.asarray(clip.angles01, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        off = np.abs(a01 - normalise(a, profile)) > _ANGLES01_TOL
    m["angles01"] = _first(off | (np.isfinite(a01) != np.isfinite(a)))

    audio = np.asarray(clip.audio)
    m["audio_frames"] = float(len(audio))
    m["angle_frames"] = float(len(a))
    if len(audio) != len(a):
        m["audio"] = float(min(len(audio), len(a)))
    else:
        m["audio"] = _first(~np.isfinite(audio))
    return InvariantMetrics(**m)


def invariant_reasons(metrics: InvariantMetrics, config: QCConfig) -> list[str]:
    """One reason per broken invariant in `metrics`, naming it and the frame; clips measured
    before the invariants existed (NaN) break none."""

    def get(value: float | None) -> float:
        return float(value) if value is not None else _NAN

    def at(frame: float) -> int | None:  # NaN: measured before the invariants existed
        return int(frame) if math.isfinite(frame) and frame >= 0 else None

    m = metrics
    reasons = []
    if (k := at(m.speed)) is not None:
        joint = JOINTS[int(get(m.speed_joint))]
        reasons.append(
            f"invariant speed broken at frame {k}: {joint} steps {get(m.speed_ratio):.1f}"
            f"× its joint speed (max {config.max_speed_factor:g}×)"
        )
    if (k := at(m.jerk)) is not None:
        reasons.append(
            f"invariant jerk broken (largest at frame {k}): processed jerk "
            f"{get(m.jerk_ratio):.2g}× the raw jerk (max 1×)"
        )
    if (k := at(m.mask)) is not None:
        reasons.append(f"invariant mask broken at frame {k}: angles finite where mask is not")
    if (k := at(m.limits)) is not None:
        joint = JOINTS[int(get(m.limits_joint))]
        reasons.append(f"invariant limits broken at frame {k}: {joint} outside its limits")
    if (k := at(m.angles01)) is not None:
        reasons.append(f"invariant angles01 broken at frame {k}: not the normalised angles")
    if (k := at(m.audio)) is not None:
        n, want = int(get(m.audio_frames)), int(get(m.angle_frames))
        what = "features not finite" if n == want else f"{n} audio frames for {want} angle frames"
        reasons.append(f"invariant audio broken at frame {k}: {what}")
    return reasons
