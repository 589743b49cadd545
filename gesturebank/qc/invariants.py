"""Invariants every written clip must hold, measured where the builder writes it (and again by
`gesturebank qc`), as metrics so that every later re-judging keeps them:

- speed: no processed angle steps between two samples more than `qc.max_speed_factor` × the
  robot profile's joint speed allows (a jump across a joint's range breaks it);
- jerk: the processed jerk (Eq. 3.21) is not above the raw jerk: processing never adds motion;
- mask: the processed angles are finite exactly where `mask` is true;
- limits: the processed angles lie inside the profile's limits;
- angles01: `angles01` is `angles` normalised (Eq. 3.13–3.14);
- audio: the audio features are finite and as many frames as the angles.

Each is stored as `invariant/<name>` (−1 = holds, else the first frame that breaks it; speed,
jerk: the worst one) with the numbers its reason quotes (no NaN, so that two builds compare
equal); `invariant_reasons` turns them into one reason each that names the invariant and the
frame.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from gesturebank.clip import Clip
from gesturebank.config import QCConfig
from gesturebank.robot.pepper import JOINTS, RobotProfile, normalise

NAMES = ("speed", "jerk", "mask", "limits", "angles01", "audio")
_ANGLES01_TOL = 1e-4  # float32 rounding of (θ − lower) / (upper − lower)
# Jerk (Eq. 3.21) of float32 rounding alone: Δ³θ ~ 3e-7 rad gives ½·100⁵·(3e-7)² ≈ 5e-4 rad² s⁻⁵
# at 100 Hz, while a person's clips measure 1e2–1e9: below this, "more jerk" is rounding noise.
_JERK_NOISE = 1e-2
_NAN = math.nan


HOLDS = -1.0


def _first(bad: np.ndarray) -> float:
    """Index of the first True frame of `bad (N, ...)`, HOLDS when none."""
    rows = np.flatnonzero(np.asarray(bad).reshape(len(bad), -1).any(axis=1))
    return float(rows[0]) if len(rows) else HOLDS


def invariant_metrics(
    clip: Clip, *, profile: RobotProfile, qc: QCConfig, jerk: float, jerk_raw: float
) -> dict[str, float]:
    """The invariants of one clip as metrics (module docstring); `jerk`, `jerk_raw`: the clip's
    processed and raw J (`qc.metrics.clip_metrics`)."""
    a = np.asarray(clip.angles, dtype=np.float64)
    rate = 1.0 / float(np.median(np.diff(clip.times))) if len(clip.times) > 1 else 100.0
    m: dict[str, float] = {f"invariant/{n}": HOLDS for n in NAMES}

    steps = np.abs(np.diff(a, axis=0)) * rate / profile.velocity  # × the joint speed
    if np.isfinite(steps).any():
        frame, joint = np.unravel_index(np.nanargmax(steps), steps.shape)
        m["invariant/speed_ratio"] = float(steps[frame, joint])
        if steps[frame, joint] > qc.max_speed_factor:
            m["invariant/speed"] = float(frame + 1)
            m["invariant/speed_joint"] = float(joint)

    if jerk_raw > 0 and math.isfinite(jerk):
        m["invariant/jerk_ratio"] = jerk / jerk_raw
    if jerk > max(jerk_raw, _JERK_NOISE):  # NaN either side: not measured
        d3 = np.abs(a[3:] - 3 * a[2:-1] + 3 * a[1:-2] - a[:-3])
        if np.isfinite(d3).any():
            m["invariant/jerk"] = float(np.unravel_index(np.nanargmax(d3), d3.shape)[0] + 1)

    m["invariant/mask"] = _first(np.isfinite(a) != np.asarray(clip.mask, dtype=bool))

    with np.errstate(invalid="ignore"):
        outside = (a < profile.lower) | (a > profile.upper)
    m["invariant/limits"] = _first(outside)
    if outside.any():
        m["invariant/limits_joint"] = float(np.flatnonzero(outside[int(m["invariant/limits"])])[0])

    a01 = np.asarray(clip.angles01, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        off = np.abs(a01 - normalise(a, profile)) > _ANGLES01_TOL
    m["invariant/angles01"] = _first(off | (np.isfinite(a01) != np.isfinite(a)))

    audio = np.asarray(clip.audio)
    m["invariant/audio_frames"] = float(len(audio))
    m["invariant/angle_frames"] = float(len(a))
    if len(audio) != len(a):
        m["invariant/audio"] = float(min(len(audio), len(a)))
    else:
        m["invariant/audio"] = _first(~np.isfinite(audio))
    return m


def invariant_reasons(metrics: Mapping[str, float], config: QCConfig) -> list[str]:
    """One reason per broken invariant in `metrics` (`invariant_metrics` keys), naming it and
    the frame; clips measured before the invariants existed (no keys) break none."""

    def get(key: str) -> float:
        value = metrics.get(key, _NAN)
        return float(value) if value is not None else _NAN

    def at(key: str) -> int | None:
        frame = get(f"invariant/{key}")  # NaN: measured before the invariants existed
        return int(frame) if math.isfinite(frame) and frame >= 0 else None

    reasons = []
    if (k := at("speed")) is not None:
        joint = JOINTS[int(get("invariant/speed_joint"))]
        reasons.append(
            f"invariant speed broken at frame {k}: {joint} steps {get('invariant/speed_ratio'):.1f}"
            f"× its joint speed (max {config.max_speed_factor:g}×)"
        )
    if (k := at("jerk")) is not None:
        reasons.append(
            f"invariant jerk broken (largest at frame {k}): processed jerk "
            f"{get('invariant/jerk_ratio'):.2g}× the raw jerk (max 1×)"
        )
    if (k := at("mask")) is not None:
        reasons.append(f"invariant mask broken at frame {k}: angles finite where mask is not")
    if (k := at("limits")) is not None:
        joint = JOINTS[int(get("invariant/limits_joint"))]
        reasons.append(f"invariant limits broken at frame {k}: {joint} outside its limits")
    if (k := at("angles01")) is not None:
        reasons.append(f"invariant angles01 broken at frame {k}: not the normalised angles")
    if (k := at("audio")) is not None:
        n, want = int(get("invariant/audio_frames")), int(get("invariant/angle_frames"))
        what = "features not finite" if n == want else f"{n} audio frames for {want} angle frames"
        reasons.append(f"invariant audio broken at frame {k}: {what}")
    return reasons
