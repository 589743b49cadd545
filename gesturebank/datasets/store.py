"""The dataset on disk (DESIGN.md "Dataset on disk"), written take by take, read lazily.

    out/dataset.json         schema version, tool version, resolved config, joints, limits, rates,
                             audio feature spec, normalisation stats
    out/manifest.parquet     one row per take (take_id, subject, source, duration_s, video_fps,
                             detector, lifter, qc_status, qc_reasons, metrics, …)
    out/takes/<id>.npz       the arrays of a built take
    out/takes/<id>.json      its manifest row; written after the .npz, so it marks a take as done

Every file is written atomically (temporary name, then rename). A take whose record carries the
current config digest is "built" and skipped on a re-run; failed takes are retried. The manifest
is consolidated from the per-take records, which is also how Ray workers hand back results.
Nothing is ever unpickled.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from gesturebank.errors import InputError
from gesturebank.fileio import atomic_open, write_bytes_atomic

SCHEMA_VERSION = 1
DATASET_JSON = "dataset.json"
MANIFEST = "manifest.parquet"
TAKES_DIR = "takes"

Status = Literal["accepted", "rejected", "failed"]
STATUSES: tuple[Status, ...] = ("accepted", "rejected", "failed")

# Manifest columns every reader can rely on (more may follow; none is ever renamed).
MANIFEST_SCHEMA = pa.schema(
    [
        ("take_id", pa.string()),
        ("subject", pa.string()),
        ("source", pa.string()),
        ("duration_s", pa.float64()),
        ("video_fps", pa.float64()),
        ("detector", pa.string()),
        ("lifter", pa.string()),
        ("qc_status", pa.string()),
        ("qc_reasons", pa.list_(pa.string())),
        ("metrics", pa.map_(pa.string(), pa.float64())),
        ("n_frames", pa.int64()),
        ("config_digest", pa.string()),
        ("traits", pa.map_(pa.string(), pa.string())),
    ]
)


@dataclass(frozen=True)
class TakeRecord:
    """One manifest row."""

    take_id: str
    subject: str
    source: str
    qc_status: Status
    config_digest: str
    duration_s: float = float("nan")
    video_fps: float = float("nan")
    detector: str = ""
    lifter: str = ""
    qc_reasons: tuple[str, ...] = ()
    metrics: Mapping[str, float] | None = None
    n_frames: int = 0
    traits: Mapping[str, str] | None = None

    def __post_init__(self) -> None:
        if self.qc_status not in STATUSES:
            raise ValueError(f"qc_status must be one of {STATUSES}, got {self.qc_status!r}")

    def to_json_dict(self) -> dict[str, Any]:
        return {
            "take_id": self.take_id,
            "subject": self.subject,
            "source": self.source,
            "duration_s": self.duration_s,
            "video_fps": self.video_fps,
            "detector": self.detector,
            "lifter": self.lifter,
            "qc_status": self.qc_status,
            "qc_reasons": list(self.qc_reasons),
            "metrics": {k: float(v) for k, v in (self.metrics or {}).items()},
            "n_frames": int(self.n_frames),
            "config_digest": self.config_digest,
            "traits": dict(self.traits or {}),
        }

    @classmethod
    def from_json_dict(cls, d: Mapping[str, Any]) -> TakeRecord:
        return cls(
            take_id=d["take_id"],
            subject=d["subject"],
            source=d["source"],
            qc_status=d["qc_status"],
            config_digest=d["config_digest"],
            duration_s=float(d.get("duration_s", float("nan"))),
            video_fps=float(d.get("video_fps", float("nan"))),
            detector=d.get("detector", ""),
            lifter=d.get("lifter", ""),
            qc_reasons=tuple(d.get("qc_reasons", ())),
            metrics=dict(d.get("metrics", {})),
            n_frames=int(d.get("n_frames", 0)),
            traits=dict(d.get("traits", {})),
        )


def take_npz(out: Path, take_id: str) -> Path:
    return Path(out) / TAKES_DIR / f"{take_id}.npz"


def take_json(out: Path, take_id: str) -> Path:
    return Path(out) / TAKES_DIR / f"{take_id}.json"


def write_take(out: Path, record: TakeRecord, arrays: Mapping[str, np.ndarray] | None) -> None:
    """Write a take's arrays (none for a failed take), then its record, each atomically."""
    npz = take_npz(out, record.take_id)
    if arrays is not None:
        for name, value in arrays.items():
            if np.asarray(value).dtype == object:
                raise InputError(f"{npz}: array {name!r} has dtype object")
        with atomic_open(npz) as f:
            np.savez_compressed(f, allow_pickle=False, **arrays)
    else:
        npz.unlink(missing_ok=True)  # a failed rebuild must not leave an older take behind
    write_record(out, record)


def write_record(out: Path, record: TakeRecord) -> None:
    """Write (or rewrite, e.g. after QC) a take's record atomically."""
    text = json.dumps(record.to_json_dict(), indent=1, allow_nan=True)
    write_bytes_atomic(take_json(out, record.take_id), text.encode())


def remove_stale_temporaries(out: Path) -> int:
    """Delete temporary files a killed build left in takes/ (call before any worker starts)."""
    stale = list((Path(out) / TAKES_DIR).glob(".*.tmp"))
    for path in stale:
        path.unlink(missing_ok=True)
    return len(stale)


def read_record(out: Path, take_id: str) -> TakeRecord | None:
    """The take's record, or None when it has none (or an unreadable one: it gets rebuilt)."""
    try:
        return TakeRecord.from_json_dict(json.loads(take_json(out, take_id).read_text()))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def is_built(out: Path, take_id: str, config_digest: str) -> bool:
    """True when the take was built (accepted or rejected) with this config and its data exist."""
    record = read_record(out, take_id)
    return (
        record is not None
        and record.config_digest == config_digest
        and record.qc_status != "failed"
        and take_npz(out, take_id).is_file()
    )


def records(out: Path) -> list[TakeRecord]:
    """Every readable per-take record, sorted by take id."""
    folder = Path(out) / TAKES_DIR
    found = []
    for path in sorted(folder.glob("*.json")):
        record = read_record(out, path.stem)
        if record is not None:
            found.append(record)
    return found


def write_manifest(out: Path, take_ids: list[str] | None = None) -> pa.Table:
    """Consolidate the per-take records (only `take_ids` when given) into manifest.parquet."""
    rows = [r.to_json_dict() for r in records(out)]
    if take_ids is not None:
        wanted = set(take_ids)
        rows = [r for r in rows if r["take_id"] in wanted]
    for r in rows:
        r["metrics"] = list(r["metrics"].items())
        r["traits"] = list(r["traits"].items())
    table = pa.Table.from_pylist(rows, schema=MANIFEST_SCHEMA)
    with atomic_open(Path(out) / MANIFEST) as f:
        pq.write_table(table, f)
    return table


def write_dataset_json(out: Path, info: Mapping[str, Any]) -> None:
    data = {"schema_version": SCHEMA_VERSION, **info}
    write_bytes_atomic(Path(out) / DATASET_JSON, json.dumps(data, indent=1).encode())


class Dataset:
    """A built dataset folder, read lazily: arrays are loaded one take at a time."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        meta = self.path / DATASET_JSON
        try:
            self.info: dict[str, Any] = json.loads(meta.read_text())
        except FileNotFoundError:
            raise InputError(f"{meta}: not found — is {self.path} a gesturebank dataset?") from None
        except ValueError as exc:
            raise InputError(f"{meta}: not valid JSON ({exc})") from None
        version = self.info.get("schema_version")
        if version != SCHEMA_VERSION:
            raise InputError(f"{meta}: schema_version {version}, this gesturebank reads 1")
        try:
            self.manifest: pa.Table = pq.read_table(self.path / MANIFEST)
        except (OSError, pa.ArrowInvalid) as exc:
            raise InputError(f"{self.path / MANIFEST}: cannot read ({exc})") from None

    def __len__(self) -> int:
        return self.manifest.num_rows

    def records(self) -> list[dict[str, Any]]:
        rows = self.manifest.to_pylist()
        for r in rows:
            r["metrics"] = dict(r["metrics"] or [])
            r["traits"] = dict(r["traits"] or [])
        return rows

    def take_ids(self, status: Status | None = "accepted") -> list[str]:
        """Take ids with this QC status (all statuses when None)."""
        return [r["take_id"] for r in self.records() if status is None or r["qc_status"] == status]

    def load(self, take_id: str) -> dict[str, np.ndarray]:
        """All arrays of one take (never unpickled)."""
        path = take_npz(self.path, take_id)
        try:
            with np.load(path, allow_pickle=False) as data:
                return {k: data[k] for k in data.files}
        except (OSError, ValueError) as exc:
            raise InputError(f"{path}: cannot read take ({exc})") from None

    def __iter__(self) -> Iterator[tuple[dict[str, Any], dict[str, np.ndarray]]]:
        """(record, arrays) of every built (accepted or rejected) take, loaded one at a time."""
        for record in self.records():
            if record["qc_status"] != "failed":
                yield record, self.load(record["take_id"])
