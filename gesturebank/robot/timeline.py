"""Angle timelines: what the player plays, and the one file format every command reads and writes.

The format (written by `synthesize`, `export --format csv`, `live/replay --backend record` as CSV):

    # gesturebank angle timeline; robot profile: pepper-1.7; unit: rad; reach: clamp
    time_s,HeadPitch,HeadYaw,LShoulderRoll,…,HipRoll
    0.0125,0.012345,…

one row per frame: time in seconds on the audio's clock (0 = first audio sample), the 11 joints of
`pepper.JOINTS` in radians (NAOqi signs and zeros). An empty cell is an angle that is not known
(a masked joint, e.g. the arms of a head-only clip): a player holds the last known value there.
`read_timeline` also reads the older dialects — no comment line; `HeadPitch_rad` columns; columns
in any order — and the JSON lines a `record` backend writes (the frames it was sent).
"""

from __future__ import annotations

import csv
import io
import json
import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from gesturebank.errors import InputError
from gesturebank.fileio import output_errors, write_bytes_atomic
from gesturebank.robot.pepper import JOINTS

TIME_COLUMN = "time_s"
TITLE = "gesturebank angle timeline"
UNITS = {"rad": 1.0, "deg": np.pi / 180}  # unit named in the header → radians per unit
REACHES = ("clamp", "soft")  # how the retargeting treated targets beyond the arm's reach
RECORD_PHASES = ("timeline", "live")  # the frames of a record file that are the timeline


@dataclass(frozen=True, eq=False)
class Timeline:
    """times `(N,)` float64 s, strictly rising; angles `(N, 11)` float32 rad, `JOINTS` order,
    finite (what a robot is sent: unknown angles already held). known `(N, 11)` bool: False
    where the angle was not known (None: all known). profile, reach: the robot profile the
    angles are for and the retargeting's reach mode, when the source says so."""

    times: np.ndarray
    angles: np.ndarray
    known: np.ndarray | None = None
    profile: str | None = None
    reach: str | None = None

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
        if self.known is not None and self.known.shape != a.shape:
            raise InputError(f"timeline: known mask {self.known.shape}, angles {a.shape}")

    @classmethod
    def of(
        cls,
        times: np.ndarray,
        angles: np.ndarray,
        *,
        profile: str | None = None,
        reach: str | None = None,
    ) -> Timeline:
        """Build from any array-likes (copied to float64 times, float32 angles). NaN angles are
        unknown: held (`hold`) and marked in `known`."""
        a = np.asarray(angles, np.float64)
        known = np.isfinite(a)
        return cls(
            np.asarray(times, np.float64).copy(),
            hold(a).astype(np.float32),
            None if known.all() else known,
            profile,
            reach,
        )

    def __len__(self) -> int:
        return len(self.times)

    @property
    def masked(self) -> np.ndarray:
        """`(N, 11)` float32 angles with NaN where unknown (what the file holds)."""
        out = self.angles.copy()
        if self.known is not None:
            out[~self.known] = np.nan
        return out

    @property
    def period(self) -> float:
        """Median frame period, seconds (0.01 at the dataset's 100 Hz; 0.01 for one frame)."""
        return float(np.median(np.diff(self.times))) if len(self.times) > 1 else 0.01

    @property
    def end(self) -> float:
        """Time at which the last frame's period ends, seconds."""
        return float(self.times[-1]) + self.period


def hold(angles: np.ndarray) -> np.ndarray:
    """`angles (N, 11)` with each NaN replaced by the last known value of its joint (the first
    known one before it; the neutral pose for a joint never known), so a robot never gets NaN."""
    from gesturebank.robot.pepper import neutral_pose

    a = np.array(angles, dtype=np.float64)
    for j in range(a.shape[1]):
        col = a[:, j]
        known = np.isfinite(col)
        if not known.any():
            col[:] = neutral_pose()[j]
            continue
        last = np.maximum.accumulate(np.where(known, np.arange(len(col)), -1))
        col[:] = np.where(last >= 0, col[np.maximum(last, 0)], col[np.flatnonzero(known)[0]])
    return a


# --------------------------------------------------------------------------------------------------
# Writing


def header_line(*, profile: str | None, reach: str | None, unit: str = "rad") -> str:
    """The comment line that opens a timeline file (no newline)."""
    return (
        f"# {TITLE}; robot profile: {profile or 'unknown'}; unit: {unit}; reach: {reach or 'clamp'}"
    )


def format_timeline(timeline: Timeline) -> str:
    """The file text of `timeline` (times to 0.1 ms, angles to 1 µrad, unknown ones empty)."""
    out = io.StringIO(newline="")
    out.write(header_line(profile=timeline.profile, reach=timeline.reach) + "\n")
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow([TIME_COLUMN, *JOINTS])
    for t, row in zip(timeline.times, timeline.masked, strict=True):
        writer.writerow([f"{t:.4f}", *("" if not np.isfinite(v) else f"{v:.6f}" for v in row)])
    return out.getvalue()


def write_timeline(path: str | os.PathLike[str], timeline: Timeline) -> Path:
    """Write `timeline` in the format of the module docstring (atomically); returns the path."""
    out = Path(path)
    with output_errors(out, "the angle CSV"):
        write_bytes_atomic(out, format_timeline(timeline).encode("utf-8"))
    return out


# --------------------------------------------------------------------------------------------------
# Reading


def read_timeline(path: str | os.PathLike[str]) -> Timeline:
    """Read an angle timeline (any dialect of the module docstring, or a record backend's JSON
    lines); InputError naming the file (and line) on any problem."""
    name = os.fspath(path)
    if os.path.isdir(name):
        raise InputError(
            f"{name}: a folder, not an angle timeline (a dataset's clip: --clip CLIP_ID; "
            "`gesturebank clips` lists them)"
        )
    try:
        with open(name, newline="", encoding="utf-8") as f:
            text = f.read()
    except FileNotFoundError:
        raise InputError(f"{name}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{name}: cannot read ({exc})") from None
    if text.lstrip().startswith("{"):
        return _from_record(name, text)
    return _from_csv(name, text)


def _comment_fields(line: str) -> dict[str, str]:
    """`# a; key: value; …` → {key: value} (parts without a colon are ignored)."""
    fields = {}
    for part in line.lstrip("#").split(";"):
        key, sep, value = part.partition(":")
        if sep:
            fields[key.strip().lower()] = value.strip()
    return fields


def _column(name: str) -> tuple[str, str | None]:
    """A header cell → (joint or time column, its unit suffix if any): HeadPitch_rad → rad."""
    base, sep, unit = name.strip().rpartition("_")
    if sep and unit in UNITS and base in JOINTS:
        return base, unit
    return name.strip(), None


def _from_csv(name: str, text: str) -> Timeline:
    lines = list(enumerate(csv.reader(io.StringIO(text, newline="")), start=1))
    fields: dict[str, str] = {}
    rows = []
    for number, row in lines:
        if row and row[0].lstrip().startswith("#"):
            fields.update(_comment_fields(",".join(row)))
        elif any(cell.strip() for cell in row):
            rows.append((number, row))
    if not rows:
        raise InputError(f"{name}: empty file, expected a header {TIME_COLUMN},{','.join(JOINTS)}")
    header_no, header = rows[0]
    columns = [_column(h) for h in header]
    names = [c for c, _ in columns]
    missing = [c for c in (TIME_COLUMN, *JOINTS) if c not in names]
    if missing:
        raise InputError(f"{name}: header lacks column(s) {', '.join(missing)}")
    units = {u for c, u in columns if c in JOINTS and u is not None}
    unit = fields.get("unit", units.pop() if len(units) == 1 else "rad")
    if unit not in UNITS or units - {unit}:
        raise InputError(f"{name}: line {header_no}: angles in {unit!r}; expected one of rad, deg")
    reach = fields.get("reach")
    if reach is not None and reach not in REACHES:
        raise InputError(f"{name}: reach {reach!r}; expected one of {', '.join(REACHES)}")
    order = [names.index(c) for c in (TIME_COLUMN, *JOINTS)]
    body = rows[1:]
    values = np.empty((len(body), len(order)), dtype=np.float64)
    for i, (number, row) in enumerate(body):
        try:
            cells = [row[k].strip() for k in order]
            if not cells[0]:
                raise ValueError
            values[i] = [float(c) if c else np.nan for c in cells]  # empty: unknown
        except (IndexError, ValueError):
            raise InputError(f"{name}: line {number}: expected {len(header)} numbers") from None
        if not np.all(np.isfinite(values[i][[k for k, c in enumerate(cells) if c]])):
            raise InputError(f"{name}: line {number}: not a finite number")
    if not len(values):
        raise InputError(f"{name}: no frames after the header")
    if len(values) > 1 and not np.all(np.diff(values[:, 0]) > 0):
        number = body[int(np.flatnonzero(np.diff(values[:, 0]) <= 0)[0]) + 1][0]
        raise InputError(f"{name}: line {number}: {TIME_COLUMN} must increase")
    profile = fields.get("robot profile")
    return Timeline.of(
        values[:, 0],
        values[:, 1:] * UNITS[unit],
        profile=None if profile in (None, "unknown") else profile,
        reach=reach,
    )


def _from_record(name: str, text: str) -> Timeline:
    """The frames a record backend was sent in its timeline (replay) or live phase."""
    times: list[float] = []
    rows: list[list[float]] = []
    head: dict[str, object] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        try:
            obj = json.loads(line)
            if "call" not in obj:
                head = obj
                continue
            if obj.get("phase") not in RECORD_PHASES:
                continue
            order = [list(obj["names"]).index(j) for j in JOINTS]
            if obj["call"] == "setAngles":
                times.append(float(obj["t"]))
                rows.append([float(obj["angles"][k]) for k in order])
            elif obj["call"] == "angleInterpolation":
                lists = [obj["angleLists"][k] for k in order]
                for i, dt in enumerate(obj["timeLists"][0]):
                    times.append(float(obj["t"]) + float(dt))
                    rows.append([float(col[i]) for col in lists])
        except (ValueError, KeyError, IndexError, TypeError):
            raise InputError(
                f"{name}: line {number}: not a record backend's JSON line (an angle timeline is "
                "a CSV, or the .jsonl of a record backend)"
            ) from None
    if not rows:
        raise InputError(f"{name}: no {' or '.join(RECORD_PHASES)} frames in this record file")
    t = np.asarray(times)
    if len(t) > 1 and not np.all(np.diff(t) > 0):
        raise InputError(f"{name}: frame times must increase")
    profile = head.get("profile")
    reach = head.get("reach")
    return Timeline.of(
        t,
        np.asarray(rows),
        profile=profile if isinstance(profile, str) else None,
        reach=reach if isinstance(reach, str) else None,
    )


def reach_of(config: object) -> str:
    """The reach mode a `Config` retargets with ("clamp" when it has none: older configs)."""
    reach = getattr(getattr(config, "retarget", None), "reach", None)
    return reach if isinstance(reach, str) else REACHES[0]


def with_source(timeline: Timeline, *, profile: str | None, reach: str | None) -> Timeline:
    """`timeline` naming the profile and reach given where it names none itself."""
    return replace(timeline, profile=timeline.profile or profile, reach=timeline.reach or reach)
