"""Raw Pepper angles at the video's timestamps → the dataset's 100 Hz angles (docs/architecture.md
"Data flow": process): made continuous (`robot.reach.continuous`), interpolated onto the
clip's frame clock (short gaps only), the zero-phase Butterworth low-pass of §4.2.3, brought into
the robot's reach (`[retarget] reach`: clamped or softly compressed), kept within the robot's
joint speed (`processing.max_speed`), normalised to [0, 1] (Eq. 3.13–3.14). The builder, the QC
and the QC's corruption benchmark use these functions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gesturebank.config import ProcessingConfig, RetargetConfig
from gesturebank.filters import GapReport, butter_lowpass, interpolate_at
from gesturebank.robot import pepper
from gesturebank.robot.reach import out_of_reach, reach_map, speed_limit, unlimited_angles


@dataclass(frozen=True)
class ProcessedAngles:
    """angles, angles01 (N, 11) float32 (NaN where unknown), mask (N, 11) bool (known), the
    person's low-passed angles before the reach map (`unlimited`, float64), the gaps
    interpolation met, and the share of known values beyond the robot's reach."""

    angles: np.ndarray
    angles01: np.ndarray
    mask: np.ndarray
    unlimited: np.ndarray
    gaps: GapReport
    out_of_reach_fraction: float


def process_angles(
    *,
    raw: np.ndarray,
    timestamps: np.ndarray,
    clock: np.ndarray,
    processing: ProcessingConfig,
    retarget: RetargetConfig,
    profile: pepper.RobotProfile,
) -> ProcessedAngles:
    """`raw (T, 11)` rad at `timestamps (T,)` → the processed angles on `clock (N,)` (seconds,
    uniform at processing.rate_hz). NaN in `raw` (an unseen limb) stays NaN unless it is a gap
    of at most processing.max_gap_s; each finite run is low-passed on its own. The reach map
    (`robot.reach.reach_map`) is applied here, once, to the low-passed continuous angles."""
    smooth, gaps = unlimited_angles(
        raw=raw, timestamps=timestamps, clock=clock, processing=processing, profile=profile
    )
    limited = reach_map(smooth, profile=profile, retarget=retarget)
    step = profile.velocity * processing.max_speed / processing.rate_hz
    limited = pepper.clamp(speed_limit(limited, step).astype(np.float32), profile)
    finite = np.isfinite(smooth)
    beyond = out_of_reach(smooth, profile) & finite
    return ProcessedAngles(
        angles=limited,
        angles01=pepper.normalise(limited, profile).astype(np.float32),
        mask=finite,
        unlimited=smooth,
        gaps=gaps,
        out_of_reach_fraction=float(beyond.sum() / max(1, finite.sum())),
    )


def head_roll_at(
    roll: np.ndarray,
    *,
    timestamps: np.ndarray,
    clock: np.ndarray,
    known: np.ndarray,
    processing: ProcessingConfig,
) -> np.ndarray:
    """`roll (T,)` rad at the video's `timestamps` → `(N,)` float32 on the 100 Hz `clock`, as
    the head's angles are processed (short gaps interpolated, the same low-pass; no robot
    limits: Pepper has no roll joint), NaN where the head is not `known (N,)`."""
    values, _ = interpolate_at(
        roll[:, None], timestamps, query=clock, max_gap_s=processing.max_gap_s
    )
    smooth = butter_lowpass(
        values, processing.rate_hz, cutoff_hz=processing.cutoff_hz, order=processing.butter_order
    )[:, 0]
    return np.where(known, smooth, np.nan).astype(np.float32)
