"""Angles as CSV with their units in the header, for spreadsheets and plotting tools.

    # robot profile: pepper-1.7; angles in radians, NAOqi signs and zeros; time from the start
    time_s,HeadPitch_rad,HeadYaw_rad,…,HipRoll_rad
    0.0000,0.012345,…

Unknown (masked) angles are empty cells. `pandas.read_csv(path, comment="#")` reads it.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from gesturebank.fileio import write_bytes_atomic
from gesturebank.robot.pepper import JOINTS

HEADER = ("time_s", *(f"{j}_rad" for j in JOINTS))


def format_angles_csv(*, times: np.ndarray, angles: np.ndarray, profile: str) -> str:
    """The CSV text of `angles (N, 11)` rad at `times (N,)` s for the robot profile named."""
    out = io.StringIO()
    out.write(
        f"# robot profile: {profile}; angles in radians, NAOqi signs and zeros; "
        "time in seconds from the start\n"
    )
    out.write(",".join(HEADER) + "\n")
    for t, row in zip(np.asarray(times), np.asarray(angles), strict=True):
        cells = ["" if not np.isfinite(v) else f"{v:.6f}" for v in row]
        out.write(f"{t:.4f}," + ",".join(cells) + "\n")
    return out.getvalue()


def write_angles_csv(
    path: str | os.PathLike[str], *, times: np.ndarray, angles: np.ndarray, profile: str
) -> Path:
    out = Path(path)
    write_bytes_atomic(out, format_angles_csv(times=times, angles=angles, profile=profile).encode())
    return out
