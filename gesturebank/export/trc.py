"""TRC marker files (OpenSim, Pose2Sim): tab-separated, a 5-line header, then one row per frame.

    PathFileType  4  (X/Y/Z)  <file name>
    DataRate  CameraRate  NumFrames  NumMarkers  Units  OrigDataRate  OrigDataStartFrame
        OrigNumFrames  (one line)
    <the eight values>
    Frame#  Time  <marker 1>  <tab>  <tab>  <marker 2> …
    <tab>  <tab>  X1  Y1  Z1  X2  Y2  Z2 …

then a blank line and the rows `frame (from 1), time (s), x y z per marker`; a missing marker's
three cells are empty.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from gesturebank.errors import InputError
from gesturebank.fileio import write_bytes_atomic


def format_trc(
    *, markers: np.ndarray, names: Sequence[str], rate_hz: float, filename: str, units: str = "m"
) -> str:
    """The text of a TRC file of `markers (T, M, 3)` (NaN = missing) sampled at `rate_hz`."""
    m = np.asarray(markers, dtype=np.float64)
    if m.ndim != 3 or m.shape[1:] != (len(names), 3):
        raise InputError(f"TRC: markers must have shape (T, {len(names)}, 3), got {m.shape}")
    n, k = m.shape[:2]
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{filename}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame"
        "\tOrigNumFrames",
        f"{rate_hz:g}\t{rate_hz:g}\t{n}\t{k}\t{units}\t{rate_hz:g}\t1\t{n}",
        "Frame#\tTime\t" + "\t\t\t".join(names),
        "\t\t" + "\t".join(f"X{i}\tY{i}\tZ{i}" for i in range(1, k + 1)),
        "",
    ]
    for f in range(n):
        cells = [str(f + 1), f"{f / rate_hz:.6f}"]
        cells += ["" if not np.isfinite(v) else f"{v:.6f}" for v in m[f].ravel()]
        lines.append("\t".join(cells))
    return "\n".join(lines) + "\n"


def write_trc(
    path: str | os.PathLike[str], *, markers: np.ndarray, names: Sequence[str], rate_hz: float
) -> Path:
    """Write a TRC file (metres) atomically; returns the path."""
    out = Path(path)
    text = format_trc(markers=markers, names=names, rate_hz=rate_hz, filename=out.name)
    write_bytes_atomic(out, text.encode())
    return out
