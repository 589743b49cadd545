"""Angle timelines: what the player plays. Read/written as CSV, or taken from a dataset clip.

CSV layout (as `gesturebank synthesize` writes it): a header `time_s` + the 11 joint names of
`pepper.JOINTS`, then one row per frame: time in seconds on the audio's clock (0 = first audio
sample), angles in radians. Columns may come in any order; they are returned in `JOINTS` order.
"""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gesturebank.errors import InputError
from gesturebank.robot.pepper import JOINTS

TIME_COLUMN = "time_s"


@dataclass(frozen=True, eq=False)
class Timeline:
    """times `(N,)` float64 s, strictly rising; angles `(N, 11)` float32 rad, `JOINTS` order."""

    times: np.ndarray
    angles: np.ndarray

    def __post_init__(self) -> None:
        t, a = self.times, self.angles
        if t.ndim != 1 or a.shape != (len(t), len(JOINTS)):
            raise InputError(
                f"timeline: need times (N,) and angles (N, 11), got {t.shape}, {a.shape}"
            )
        if len(t) == 0:
            raise InputError("timeline: no frames")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(a))):
            raise InputError("timeline: times and angles must be finite numbers")
        if len(t) > 1 and not np.all(np.diff(t) > 0):
            raise InputError("timeline: times must be strictly increasing")

    @classmethod
    def of(cls, times: np.ndarray, angles: np.ndarray) -> Timeline:
        """Build from any array-likes (copied to float64 times, float32 angles)."""
        return cls(np.asarray(times, np.float64).copy(), np.asarray(angles, np.float32).copy())

    def __len__(self) -> int:
        return len(self.times)

    @property
    def period(self) -> float:
        """Median frame period, seconds (0.01 at the dataset's 100 Hz; 0.01 for one frame)."""
        return float(np.median(np.diff(self.times))) if len(self.times) > 1 else 0.01

    @property
    def end(self) -> float:
        """Time at which the last frame's period ends, seconds."""
        return float(self.times[-1]) + self.period


def read_csv(path: str | os.PathLike[str]) -> Timeline:
    """Read an angle-timeline CSV; InputError naming the file (and line) on any problem."""
    name = os.fspath(path)
    try:
        with open(name, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except FileNotFoundError:
        raise InputError(f"{name}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{name}: cannot read ({exc})") from None
    if not rows:
        raise InputError(f"{name}: empty file, expected a header {TIME_COLUMN},{','.join(JOINTS)}")
    header = [h.strip() for h in rows[0]]
    missing = [c for c in (TIME_COLUMN, *JOINTS) if c not in header]
    if missing:
        raise InputError(f"{name}: header lacks column(s) {', '.join(missing)}")
    order = [header.index(c) for c in (TIME_COLUMN, *JOINTS)]
    body = [r for r in rows[1:] if any(cell.strip() for cell in r)]
    values = np.empty((len(body), len(order)), dtype=np.float64)
    for i, row in enumerate(body):
        try:
            values[i] = [float(row[k]) for k in order]
        except (IndexError, ValueError):
            raise InputError(f"{name}: line {i + 2}: expected {len(header)} numbers") from None
    if not len(values):
        raise InputError(f"{name}: no frames after the header")
    if not np.all(np.isfinite(values)):
        line = int(np.flatnonzero(~np.all(np.isfinite(values), axis=1))[0]) + 2
        raise InputError(f"{name}: line {line}: not a finite number")
    if len(values) > 1 and not np.all(np.diff(values[:, 0]) > 0):
        line = int(np.flatnonzero(np.diff(values[:, 0]) <= 0)[0]) + 3
        raise InputError(f"{name}: line {line}: {TIME_COLUMN} must increase")
    return Timeline.of(values[:, 0], values[:, 1:])


def write_csv(path: str | os.PathLike[str], timeline: Timeline) -> Path:
    """Write `timeline` as CSV (times to 0.1 ms, angles to 1 µrad); returns the path."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow([TIME_COLUMN, *JOINTS])
        for t, row in zip(timeline.times, timeline.angles, strict=True):
            writer.writerow([f"{t:.4f}", *(f"{v:.6f}" for v in row)])
    return out


def from_clip(dataset_dir: str | os.PathLike[str], clip_id: str) -> Timeline:
    """The smoothed, clamped 100 Hz angles of one dataset clip and their times (seconds from
    the clip's start). Unknown angles (an unseen limb) hold the last known value, else the
    neutral pose, so the robot never gets NaN."""
    from gesturebank import datasets
    from gesturebank.robot.pepper import neutral_pose

    arrays = datasets.open(dataset_dir).load_arrays(clip_id)
    angles = np.array(arrays["angles"], dtype=np.float64)
    for j in range(angles.shape[1]):
        col = angles[:, j]
        known = np.flatnonzero(np.isfinite(col))
        if not len(known):
            col[:] = neutral_pose()[j]
            continue
        held = np.maximum.accumulate(np.where(np.isfinite(col), np.arange(len(col)), -1))
        col[:] = np.where(held >= 0, col[np.maximum(held, 0)], col[known[0]])
    return Timeline.of(arrays["times"], angles)
