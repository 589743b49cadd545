"""`record` backend: writes exactly what would have been sent to ALMotion, one JSON line each.

Line 1 is a header `{"backend": "record", "joints": [...], "audio": path | null, "profile":
name | null, "reach": "clamp" | "soft" | null}`; then one line
per call:
- `{"call": "setAngles", "t": s, "phase": ..., "names": [...], "angles": [...],
  "fractionMaxSpeed": f}`;
- `{"call": "angleInterpolation", "t": s, "phase": ..., "names": [...], "angleLists": [[...]],
  "timeLists": [[...]], "isAbsolute": true}` (times relative to the call, as ALMotion takes them).
`t` is the playback clock (0 = audio start); angles are radians.

As CSV (`--out F.csv`, or `csv=True`): only the frames of the timeline (replay) or live phase,
as an angle timeline (`robot.timeline`), written at `close()`: what `replay` and `export` read.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np

from gesturebank.errors import InputError, RobotError
from gesturebank.robot.backends import Command
from gesturebank.robot.pepper import JOINTS, neutral_pose
from gesturebank.robot.timeline import RECORD_PHASES, Timeline, write_timeline

if TYPE_CHECKING:
    from gesturebank.config import PlaybackConfig


def _round(values: np.ndarray) -> list[float]:
    return [round(float(v), 6) for v in values]


class RecordBackend:
    """Appends every command to a JSON-lines file; the 'robot' starts in `start_pose`."""

    name = "record"

    def __init__(
        self,
        out: str | os.PathLike[str],
        *,
        audio: str | os.PathLike[str] | None = None,
        start_pose: np.ndarray | None = None,
        realtime: bool = False,
        csv: bool = False,
        profile: str | None = None,
        reach: str | None = None,
    ) -> None:
        self.path = Path(out)
        self.realtime = realtime
        self.csv = csv
        self.profile, self.reach = profile, reach  # named in the header
        self.pose = np.asarray(neutral_pose() if start_pose is None else start_pose, np.float32)
        self._frames: list[tuple[float, np.ndarray]] = []  # CSV: the timeline's frames
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file: IO[str] | None = open(self.path, "w", encoding="utf-8")
        except OSError as exc:
            raise InputError(f"{self.path}: cannot write ({exc.strerror or exc})") from None
        audio_name = os.fspath(audio) if audio is not None else None
        head = {"backend": "record", "joints": list(JOINTS), "audio": audio_name}
        self._write({**head, "profile": profile, "reach": reach})

    @property
    def connected(self) -> bool:
        return self._file is not None

    def _write(self, obj: dict[str, Any]) -> None:
        if self._file is None:
            raise RobotError(f"{self.path}: record backend already closed")
        self._file.write(json.dumps(obj, separators=(",", ":")) + "\n")

    def get_angles(self) -> np.ndarray:
        return self.pose.copy()

    def send(self, cmd: Command) -> None:
        if self.csv:  # the timeline's frames only, written at close
            if cmd.phase in RECORD_PHASES:
                self._frames.append((cmd.t, np.asarray(cmd.angles, np.float64)))
            self.pose = np.asarray(cmd.angles, np.float32)
            return
        self._write(
            {
                "call": "setAngles",
                "t": round(cmd.t, 6),
                "phase": cmd.phase,
                "names": list(JOINTS),
                "angles": _round(cmd.angles),
                "fractionMaxSpeed": cmd.fraction,
            }
        )
        self.pose = np.asarray(cmd.angles, np.float32)

    def interpolate(self, times: np.ndarray, angles: np.ndarray, *, t: float, phase: str) -> None:
        if self.csv:
            if phase in RECORD_PHASES:
                self._frames += [
                    (t + float(dt), np.asarray(a, np.float64))
                    for dt, a in zip(times, angles, strict=True)
                ]
            self.pose = np.asarray(angles[-1], np.float32)
            return
        self._write(
            {
                "call": "angleInterpolation",
                "t": round(t, 6),
                "phase": phase,
                "names": list(JOINTS),
                "angleLists": [_round(col) for col in np.asarray(angles).T],
                "timeLists": [_round(times)] * len(JOINTS),
                "isAbsolute": True,
            }
        )
        self.pose = np.asarray(angles[-1], np.float32)

    def close(self) -> None:
        if self._file is None:
            return
        self._file.close()
        self._file = None
        if self.csv:
            if not self._frames:  # nothing played (an error before the first frame)
                self.path.unlink(missing_ok=True)
                return
            times = np.array([t for t, _ in self._frames])
            angles = np.stack([a for _, a in self._frames])
            line = Timeline.of(times, angles, profile=self.profile, reach=self.reach)
            write_timeline(self.path, line)


def read_record(path: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The calls of a record file (header line skipped)."""
    with open(path, encoding="utf-8") as f:
        lines = [json.loads(line) for line in f if line.strip()]
    return [c for c in lines if "call" in c]


def create(
    *,
    url: str | None = None,
    out: str | os.PathLike[str] | None = None,
    audio: str | os.PathLike[str] | None = None,
    config: PlaybackConfig | None = None,
    csv: bool = False,
    profile: str | None = None,
    reach: str | None = None,
) -> RecordBackend:
    if out is None:
        raise InputError("--backend record needs --out TIMELINE.jsonl (or .csv)")
    as_csv = csv or Path(out).suffix.lower() == ".csv"
    return RecordBackend(out, audio=audio, csv=as_csv, profile=profile, reach=reach)
