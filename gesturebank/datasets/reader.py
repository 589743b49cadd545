"""Reading a dataset (docs/architecture.md "The dataset on disk"): `Dataset`, its manifest's
rows (`ManifestRow`) and its clips."""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from gesturebank.clip import Clip, parse_parts
from gesturebank.datasets.records import (
    MANIFEST,
    ClipRecord,
    DatasetInfo,
    Status,
    TakeRecord,
    clip_npz,
    read_clip_arrays,
    read_dataset_json,
)
from gesturebank.errors import GesturebankDeprecationWarning, InputError

# --------------------------------------------------------------------------------------------------
# The reader


@dataclass(frozen=True)
class ManifestRow:
    """One row of the manifest: a clip (or a span that gave none) and the take it belongs to.

    The take is what the manifest and dataset.json hold of it: everything but its tracking
    report, audio sums and preview times (`read_record` reads those), with `clips` the take's
    rows (none for a failed take, whose one row is a span with the reason it failed).
    """

    take: TakeRecord
    clip: ClipRecord

    def __getitem__(self, key: str) -> Any:
        """The manifest column `key`, as when rows were dicts (deprecated: read `.clip` or
        `.take`)."""
        for name, record in (("clip", self.clip), ("take", self.take)):
            if key in {f.name for f in fields(record)}:
                warnings.warn(
                    f"row[{key!r}] is deprecated: manifest rows are records, read row.{name}.{key}",
                    GesturebankDeprecationWarning,
                    stacklevel=2,
                )
                return getattr(record, key)
        raise KeyError(key)


def _manifest_rows(table: pa.Table, info: DatasetInfo) -> list[ManifestRow]:
    """The manifest's rows as records, in the manifest's order (a take's rows are together)."""
    by_take: dict[str, list[tuple[dict[str, Any], ClipRecord]]] = {}
    for r in table.to_pylist():
        for key in ("metrics", "repairs", "masked"):
            r[key] = dict(r[key] or [])
        r["qc_reasons"] = tuple(r["qc_reasons"] or ())
        by_take.setdefault(r["take_id"], []).append((r, ClipRecord.from_json_dict(r)))
    rows = []
    for take_id, parts in by_take.items():
        first = parts[0][0]
        summary = info.takes.get(take_id)
        failed = summary is not None and summary.status == "failed"
        take = TakeRecord(
            take_id=take_id,
            subject=first["subject"],
            source=first["source"],
            config_digest=first["config_digest"],
            failed="; ".join(parts[0][1].qc_reasons) if failed else "",
            detector=first["detector"],
            lifter=first["lifter"],
            video_fps=float(first["video_fps"]),
            seconds=summary.seconds if summary else 0.0,
            visible_s=summary.visible_s if summary else 0.0,
            clips=() if failed else tuple(c for _, c in parts),
            traits=dict(first["traits"] or []),
        )
        rows += [ManifestRow(take, c) for _, c in parts]
    return rows


class Dataset:
    """A built dataset folder, read lazily: a clip's arrays are loaded when asked for."""

    def __init__(self, path: str | os.PathLike[str], *, require: str | None = None) -> None:
        self.path = Path(path)
        # body parts every clip listed must have (`clips`); none required by default
        self.require: frozenset[str] = parse_parts(require) if require else frozenset()
        self.info: DatasetInfo = read_dataset_json(self.path)
        try:
            self.manifest: pa.Table = pq.read_table(self.path / MANIFEST)
        except (OSError, pa.ArrowInvalid) as exc:
            raise InputError(f"{self.path / MANIFEST}: cannot read ({exc})") from None
        self._rows = _manifest_rows(self.manifest, self.info)
        self._take_of = {
            r.clip.clip_id: r.take.take_id for r in self._rows if r.clip.kind == "clip"
        }

    def __len__(self) -> int:
        """Clips with arrays (accepted or rejected)."""
        return len(self._take_of)

    def rows(self) -> list[ManifestRow]:
        """Every manifest row (clips and spans), each a clip record with its take's."""
        return list(self._rows)

    def clips(
        self, status: Status | None = "accepted", *, require: str | None = None
    ) -> list[ManifestRow]:
        """Manifest rows of the clips with arrays with this QC status (any when None) that have
        every body part `require` names (e.g. "head", "arms"; None: the dataset's own `require`,
        set by `open`)."""
        need = self.require if require is None else parse_parts(require)
        return [
            r
            for r in self._rows
            if r.clip.kind == "clip"
            and (status is None or r.clip.qc_status == status)
            and need <= parse_parts(r.clip.parts or "none")
        ]

    def clip_ids(
        self, status: Status | None = "accepted", *, require: str | None = None
    ) -> list[str]:
        return [r.clip.clip_id for r in self.clips(status, require=require)]

    def load_arrays(self, clip_id: str) -> dict[str, np.ndarray]:
        """All arrays of one clip as plain numpy (never unpickled)."""
        if clip_id not in self._take_of:
            raise InputError(f"{self.path}: no clip {clip_id!r} in the manifest")
        path = clip_npz(self.path, take_id=self._take_of[clip_id], clip_id=clip_id)
        try:
            return read_clip_arrays(path)
        except (OSError, ValueError) as exc:
            raise InputError(f"{path}: cannot read clip ({exc})") from None

    def load(self, clip_id: str) -> Clip:
        """One clip, typed."""
        return Clip.from_arrays(self.load_arrays(clip_id))

    def __iter__(self) -> Iterator[tuple[ManifestRow, Clip]]:
        """(manifest row, Clip) of every clip with arrays, loaded one at a time."""
        for row in self.clips(None):
            yield row, self.load(row.clip.clip_id)
