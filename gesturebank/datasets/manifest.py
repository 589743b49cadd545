"""Writing a dataset (docs/architecture.md "The dataset on disk"): a take's clips and record,
atomically, and the manifest consolidated from the records; reading the records back."""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from gesturebank.clip import Clip, parts_label, parts_of
from gesturebank.datasets.partners import check_partners
from gesturebank.datasets.records import (
    DEPTH_COLUMNS,
    MANIFEST,
    MANIFEST_SCHEMA,
    PREVIEW,
    TAKES_DIR,
    ClipRecord,
    TakeRecord,
    clip_npz,
    take_dir,
    take_json,
)
from gesturebank.errors import InputError
from gesturebank.fileio import atomic_open, permissions, write_bytes_atomic

# --------------------------------------------------------------------------------------------------
# Writing


def write_take(
    out: Path, *, record: TakeRecord, clips: Sequence[Clip] = (), preview: bytes | None = None
) -> None:
    """Write a take: its clips (none for a failed take) and preview into a temporary folder that
    then replaces the take's folder, then its record — each step atomic."""
    out = Path(out)
    folder = take_dir(out, record.take_id)
    folder.parent.mkdir(parents=True, exist_ok=True)
    wanted = {c.clip_id for c in record.data_clips}
    if {c.clip_id for c in clips} != wanted:
        raise ValueError(f"{record.take_id}: the record's clips and the arrays differ")
    records = {c.clip_id: c for c in record.data_clips}
    for clip in clips:  # the invariant, where it is written: the manifest's parts are the mask's
        has, said = parts_label(parts_of(clip.mask)), records[clip.clip_id].parts
        if said != has:
            raise ValueError(f"{clip.clip_id}: recorded parts {said!r}, its mask has {has!r}")
    check_partners(clips, take_id=record.take_id)  # the invariant, where clips are written
    partners = {c.clip_id: c.partner_clip_id for c in clips}
    if any(partners[c.clip_id] != c.partner_clip_id for c in record.data_clips):
        raise ValueError(f"{record.take_id}: the record's partners and the clips' differ")
    tmp = Path(tempfile.mkdtemp(dir=folder.parent, prefix=f".{record.take_id}.", suffix=".tmp"))
    os.chmod(tmp, permissions(folder=True))
    try:
        for clip in clips:
            arrays = clip.to_arrays()
            for name, value in arrays.items():
                if value.dtype == object:
                    raise InputError(f"{clip.clip_id}: array {name!r} has dtype object")
            with atomic_open(tmp / f"{clip.clip_id}.npz") as f:
                np.savez_compressed(f, allow_pickle=False, **arrays)
        if preview is not None:
            write_bytes_atomic(tmp / PREVIEW, preview)
        old = folder.with_name(f".{record.take_id}.old")
        if folder.exists():
            shutil.rmtree(old, ignore_errors=True)
            os.replace(folder, old)
        os.replace(tmp, folder)
        shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    write_record(out, record)


def write_record(out: Path, record: TakeRecord) -> None:
    """Write (or rewrite, e.g. after QC) a take's record atomically."""
    text = json.dumps(record.to_json_dict(), indent=1, allow_nan=True)
    write_bytes_atomic(take_json(out, record.take_id), text.encode())


def remove_stale_temporaries(out: Path) -> int:
    """Delete what a killed build left in takes/ (call before any worker starts)."""
    folder = Path(out) / TAKES_DIR
    stale = [*folder.glob(".*.tmp"), *folder.glob(".*.old")]
    for path in stale:
        if path.is_dir():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)
    return len(stale)


# --------------------------------------------------------------------------------------------------
# Reading records


def read_record(out: Path, take_id: str) -> TakeRecord | None:
    """The take's record, or None when it has none (or an unreadable one: it gets rebuilt)."""
    try:
        return TakeRecord.from_json_dict(json.loads(take_json(out, take_id).read_text()))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def is_built(out: Path, *, take_id: str, config_digest: str) -> bool:
    """True when the take was built with this config and every clip's arrays exist."""
    record = read_record(out, take_id)
    return (
        record is not None
        and record.config_digest == config_digest
        and not record.failed
        and all(
            clip_npz(out, take_id=take_id, clip_id=c.clip_id).is_file() for c in record.data_clips
        )
    )


def take_records(out: Path, take_ids: Sequence[str] | None = None) -> list[TakeRecord]:
    """Every readable take record (only `take_ids` when given), sorted by take id."""
    folder = Path(out) / TAKES_DIR
    names = sorted(p.stem for p in folder.glob("*.json")) if take_ids is None else take_ids
    found = [read_record(out, name) for name in sorted(names)]
    return [r for r in found if r is not None]


def with_clips(record: TakeRecord, clips: Sequence[ClipRecord]) -> TakeRecord:
    return replace(record, clips=tuple(clips))


def manifest_rows(record: TakeRecord) -> list[dict[str, Any]]:
    """The manifest rows of one take: its clips and spans (a failed take: one span)."""
    base = {
        "take_id": record.take_id,
        "subject": record.subject,
        "source": record.source,
        "video_fps": float(record.video_fps),
        "detector": record.detector,
        "lifter": record.lifter,
        "config_digest": record.config_digest,
        "traits": list(record.traits.items()),
    }
    if record.failed:
        failed = ClipRecord(
            record.take_id, "span", 0.0, record.seconds, "failed", (record.failed,), person=-1
        )
        clips: Sequence[ClipRecord] = (failed,)
    else:
        clips = record.clips
    rows = []
    for c in clips:
        d = c.to_json_dict()
        rows.append(
            {
                **base,
                **{k: d[k] for k in ("clip_id", "kind", "start_s", "end_s", "qc_status")},
                **{k: d[k] for k in ("qc_reasons", "duration_s", "n_frames", "partner_clip_id")},
                **{k: d[k] for k in ("person", "speaking_fraction")},
                "metrics": list(d["metrics"].items()),
                "repairs": list(d["repairs"].items()),
                "masked": list(d["masked"].items()),
                **{k: _known(d["metrics"].get(k)) for k in DEPTH_COLUMNS},
                "parts": d["parts"],
            }
        )
    return rows


def _known(value: float | None) -> float | None:
    """A metric for a manifest column: None (null) when not measured or NaN."""
    return float(value) if value is not None and math.isfinite(value) else None


def write_manifest(out: Path, takes: Sequence[TakeRecord]) -> pa.Table:
    """Consolidate the records of `takes` into manifest.parquet (one row per clip and span)."""
    rows = [row for record in takes for row in manifest_rows(record)]
    table = pa.Table.from_pylist(rows, schema=MANIFEST_SCHEMA)
    with atomic_open(Path(out) / MANIFEST) as f:
        pq.write_table(table, f)
    return table
