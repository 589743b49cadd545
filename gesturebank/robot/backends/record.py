"""`record` backend: writes exactly what would have been sent to ALMotion, one JSON line each.

Line 1 is a header `{"backend": "record", "joints": [...], "audio": path | null}`; then one line
per call:
- `{"call": "setAngles", "t": s, "phase": ..., "names": [...], "angles": [...],
  "fractionMaxSpeed": f}`;
- `{"call": "angleInterpolation", "t": s, "phase": ..., "names": [...], "angleLists": [[...]],
  "timeLists": [[...]], "isAbsolute": true}` (times relative to the call, as ALMotion takes them).
`t` is the playback clock (0 = audio start); angles are radians.
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
    ) -> None:
        self.path = Path(out)
        self.realtime = realtime
        self.pose = np.asarray(neutral_pose() if start_pose is None else start_pose, np.float32)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file: IO[str] | None = open(self.path, "w", encoding="utf-8")
        except OSError as exc:
            raise InputError(f"{self.path}: cannot write ({exc.strerror or exc})") from None
        audio_name = os.fspath(audio) if audio is not None else None
        self._write({"backend": "record", "joints": list(JOINTS), "audio": audio_name})

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
        if self._file is not None:
            self._file.close()
            self._file = None


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
) -> RecordBackend:
    if out is None:
        raise InputError("--backend record needs --out TIMELINE.jsonl")
    return RecordBackend(out, audio=audio)
