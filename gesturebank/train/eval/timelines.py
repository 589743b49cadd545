"""Another system's motion for a split, read from angle timelines (`robot.timeline`'s format):
one file per scored clip, named by its id (`<clip_id>.csv`, or the `.jsonl` a record backend
writes), times on the clip's audio clock as `synthesize` writes them.

Each file is sampled at the clip's frame times: linear interpolation between its frames, its
first and last frame held outside them (what a robot playing it would show). Masked cells are
held as `read_timeline` holds them: the robot shows the last known angle there, and so is scored.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from gesturebank.datasets.store import Dataset
from gesturebank.datasets.torch import Segment
from gesturebank.errors import InputError
from gesturebank.robot.timeline import Timeline, read_timeline

SUFFIXES = (".csv", ".jsonl")  # a timeline file's names, the first found is read


def sample(timeline: Timeline, times: np.ndarray) -> np.ndarray:
    """The timeline's angles `(len(times), 11)` at `times` (s): linear between its frames, its
    first/last frame held before/after them."""
    t = np.asarray(times, dtype=np.float64)
    a = timeline.angles.astype(np.float64)
    return np.stack([np.interp(t, timeline.times, a[:, j]) for j in range(a.shape[1])], axis=1)


def timeline_path(folder: Path, clip_id: str) -> Path:
    """The timeline file of `clip_id` in `folder`; InputError naming the expected file if none."""
    for suffix in SUFFIXES:
        path = folder / f"{clip_id}{suffix}"
        if path.is_file():
            return path
    raise InputError(
        f"{folder / (clip_id + SUFFIXES[0])}: no timeline for clip {clip_id} of the scored split "
        "(one file per clip, named by its id)"
    )


def system_angles(
    folder: str | os.PathLike[str], segments: Sequence[Segment], *, dataset: Dataset
) -> list[np.ndarray]:
    """Each segment's angles `(n, 11)` rad from `folder`'s timeline of its clip. InputError
    (one line, naming the file) for a missing file, a bad one, or another robot profile than
    the dataset's (a timeline that names none is taken as the dataset's)."""
    root = Path(folder)
    if not root.is_dir():
        raise InputError(f"{root}: not a folder of angle timelines")
    want = dataset.info.robot_profile
    lines: dict[str, tuple[Timeline, np.ndarray]] = {}
    out = []
    for s in segments:
        if s.clip_id not in lines:
            path = timeline_path(root, s.clip_id)
            line = read_timeline(path)
            if line.profile is not None and line.profile != want:
                raise InputError(
                    f"{path}: angles for robot profile {line.profile}; the dataset's is {want}"
                )
            lines[s.clip_id] = (line, np.asarray(dataset.load_arrays(s.clip_id)["times"]))
        line, times = lines[s.clip_id]
        out.append(sample(line, times[s.start : s.start + len(s)]).astype(np.float32))
    return out
