"""Raw Pepper angles at the video's timestamps → the dataset's 100 Hz angles (docs/architecture.md
"Data flow": process): interpolated onto the clip's frame clock (short gaps only), the
zero-phase Butterworth low-pass of §4.2.3, clamped to the robot's limits, normalised to [0, 1]
(Eq. 3.13–3.14). The builder and the QC's corruption benchmark use this one function.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gesturebank.config import ProcessingConfig
from gesturebank.filters import (
    GapReport,
    butter_lowpass,
    interpolate_at,
    unwrap_angles,
    wrap_angles,
)
from gesturebank.robot import pepper


@dataclass(frozen=True)
class ProcessedAngles:
    """angles, angles01 (N, 11) float32 (NaN where unknown), mask (N, 11) bool (known), the
    gaps interpolation met, and the share of known values that clamping held at a limit."""

    angles: np.ndarray
    angles01: np.ndarray
    mask: np.ndarray
    gaps: GapReport
    clamped_fraction: float


def process_angles(
    *,
    raw: np.ndarray,
    timestamps: np.ndarray,
    clock: np.ndarray,
    processing: ProcessingConfig,
    profile: pepper.RobotProfile,
) -> ProcessedAngles:
    """`raw (T, 11)` rad at `timestamps (T,)` → the processed angles on `clock (N,)` (seconds,
    uniform at processing.rate_hz). NaN in `raw` (an unseen limb) stays NaN unless it is a gap
    of at most processing.max_gap_s; each finite run is low-passed on its own. An angle that
    steps across ±π (beyond the robot's range, e.g. a head turned away) is interpolated and
    filtered unwrapped, then wrapped back: filtered as it is, the step would become a sweep
    through 0, across the joint's whole range."""
    p = processing
    angles, gaps = interpolate_at(unwrap_angles(raw), timestamps, clock, max_gap_s=p.max_gap_s)
    smooth = butter_lowpass(angles, p.rate_hz, cutoff_hz=p.cutoff_hz, order=p.butter_order)
    smooth = wrap_angles(smooth)
    # clamped in the stored dtype: float32(limit) can lie outside the float64 limit
    clamped = pepper.clamp(smooth.astype(np.float32), profile)
    finite = np.isfinite(smooth)
    at_limit = finite & ((smooth <= profile.lower) | (smooth >= profile.upper))
    return ProcessedAngles(
        angles=clamped.astype(np.float32),
        angles01=pepper.normalise(clamped, profile).astype(np.float32),
        mask=finite,
        gaps=gaps,
        clamped_fraction=float(at_limit.sum() / max(1, finite.sum())),
    )
