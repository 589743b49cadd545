"""`gesturebank compare`'s table: its columns, rows named by model folder, and its CSV and
Markdown forms (the command itself, which scores and prints, is `app.compare`).

Every model is scored as `evaluate` scores it (its own post-processing, then the same measures
on the same segments), with one scoring config for all and one FGD autoencoder; a row is the
mean over subjects (Table 5.1's averaging). The table is printed and, with `out`, written as
CSV (`.csv`) or Markdown (`.md`); both carry the FGD version.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Sequence
from pathlib import Path

from gesturebank.train.eval.evaluate import (
    FIELD_MEASURES,
    LEGEND,
    SEED_MEASURES,
    TABLE_5_1,
    Column,
)
from gesturebank.train.eval.tables import Footnotes, cell

PathLike = str | os.PathLike[str]
_BY_KEY = {c.key: c for c in (*TABLE_5_1, *SEED_MEASURES, *FIELD_MEASURES)}
# evaluate's columns (one name and direction per measure), a selection
COLUMNS: tuple[Column, ...] = tuple(
    _BY_KEY[k]
    for k in (
        "loss_l",
        "rmse_deg",
        "ape_deg",
        "cca",
        "lcca_theta",
        "avg_accel",
        "avg_jerk",
        "hellinger_speed",
        "hellinger_accel",
        "fgd",
        "beat_consistency",
    )
)
FORMATS = (".csv", ".md")


def model_names(dirs: Sequence[Path]) -> list[str]:
    """Row names: each folder's name, with its parent's when two names clash."""
    names = [d.name for d in dirs]
    return [f"{d.parent.name}/{d.name}" if names.count(d.name) > 1 else d.name for d in dirs]


def cells(system: str, row: dict[str, float | None], *, notes: Footnotes) -> list[str]:
    return [cell(row.get(c.key), c, mark=notes.mark(system, c.key)) for c in COLUMNS]


def to_csv(rows: dict[str, dict[str, float | None]], fgd_version: str | None) -> str:
    """system, every column key (full precision, empty where not computable), fgd_version."""
    text = io.StringIO(newline="")
    w = csv.writer(text)
    w.writerow(["system", *(c.key for c in COLUMNS), "fgd_version"])
    for name, row in rows.items():
        values = [row.get(c.key) for c in COLUMNS]
        w.writerow(
            [name, *("" if v is None else repr(float(v)) for v in values), fgd_version or ""]
        )
    return text.getvalue()


def to_markdown(
    rows: dict[str, dict[str, float | None]], *, title: str, notes: Footnotes | None = None
) -> str:
    """A Markdown table with the printed precision, titled; the legend and n/a reasons below."""
    notes = notes or Footnotes({}, {}, [])
    head = ["System", *(c.title for c in COLUMNS)]
    lines = [f"**{title}**", "", "| " + " | ".join(head) + " |"]
    lines.append("|" + "|".join(["---"] + ["---:"] * len(COLUMNS)) + "|")
    lines += [
        "| " + " | ".join([name, *cells(name, row, notes=notes)]) + " |"
        for name, row in rows.items()
    ]
    for line in [LEGEND, *notes.lines]:  # paragraphs of their own
        lines += ["", line]
    return "\n".join(lines) + "\n"
