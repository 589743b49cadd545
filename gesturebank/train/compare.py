"""`gesturebank compare`: several trained models and the baselines on one split, one table.

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
from typing import Any

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.config import TrainConfig
from gesturebank.datasets import open as open_dataset
from gesturebank.errors import InputError
from gesturebank.fileio import output_errors, write_bytes_atomic
from gesturebank.train import model_folder
from gesturebank.train.evaluate import (
    Column,
    average,
    baselines,
    not_computable,
    postprocess,
    score_systems,
)
from gesturebank.train.fgd import label as fgd_label
from gesturebank.train.field import prepare
from gesturebank.train.models import predict as torch_predict
from gesturebank.train.trainer import torch_settings

PathLike = str | os.PathLike[str]
COLUMNS: tuple[Column, ...] = (
    ("loss_l", "Loss L", 1.0, "{:.4f}"),
    ("rmse_deg", "RMSE (°)", 1.0, "{:.2f}"),
    ("ape_deg", "APE (°)", 1.0, "{:.2f}"),
    ("cca", "CCA", 1.0, "{:.3f}"),
    ("lcca_theta", "LCCA_Θ", 1.0, "{:.4f}"),
    ("avg_accel", "Acc (rad/s²)", 1.0, "{:.2f}"),
    ("avg_jerk", "Jerk (rad/s³)", 1.0, "{:.1f}"),
    ("hellinger_speed", "H vel", 1.0, "{:.3f}"),
    ("hellinger_accel", "H acc", 1.0, "{:.3f}"),
    ("fgd", "FGD", 1.0, "{:.3f}"),
    ("beat_consistency", "BC", 1.0, "{:.3f}"),
)
FORMATS = (".csv", ".md")


def _names(dirs: Sequence[Path]) -> list[str]:
    """Row names: each folder's name, with its parent's when two names clash."""
    names = [d.name for d in dirs]
    return [f"{d.parent.name}/{d.name}" if names.count(d.name) > 1 else d.name for d in dirs]


def compare_command(
    model_dirs: Sequence[PathLike],
    dataset: PathLike | None = None,
    split: str = "test",
    *,
    config: TrainConfig | None = None,
    out: PathLike | None = None,
    console: Console | None = None,
) -> dict[str, Any]:
    """Score `model_dirs` (all trained on one split of one dataset) and the baselines on split
    part `split`; print one table, write it to `out` (.csv or .md) and return
    {split, dataset, fgd_version, systems: {name → averaged measures}, notes}.

    `config` sets the scoring (default: the first model's training config).
    """
    if not model_dirs:
        raise InputError("compare needs at least one model folder")
    if out is not None and Path(out).suffix not in FORMATS:
        raise InputError(f"{out}: the table is written as .csv or .md")
    folders = [model_folder.load(d) for d in model_dirs]
    first = folders[0].info
    where = ("variant", "fold", "subject")
    for f in folders[1:]:
        if any(f.info[k] != first[k] for k in where) or (
            dataset is None and f.info["dataset"] != first["dataset"]
        ):
            raise InputError(
                f"{f.path}: trained on another split or dataset than {folders[0].path}; "
                "compare scores models of one split"
            )
    cfg = config or folders[0].train_config
    ds = open_dataset(dataset or first["dataset"])
    inputs = prepare(
        ds,
        variant=first["variant"],
        fold=first["fold"],
        subject=first["subject"],
        part=split,
        config=cfg,
    )
    segments = inputs.segments
    rate_hz = float(ds.info.rates.pose_hz)
    systems: dict[str, list[np.ndarray]] = {}
    for name, folder in zip(_names([f.path for f in folders]), folders, strict=True):
        own = folder.train_config
        net = folder.torch_model()
        with torch_settings(own.seed, own.threads):
            pred01 = [torch_predict(net, s.audio) for s in segments]
        systems[name] = [postprocess(p, folder.profile, rate_hz, own) for p in pred01]
    systems |= baselines(
        segments,
        mean_pose01=np.asarray(folders[0].norm["mean_pose01"]),
        profile=folders[0].profile,
        rate_hz=rate_hz,
        config=cfg,
        donors=inputs.donors,
    )
    results = score_systems(
        segments, systems, folders[0].profile, rate_hz, cfg, fgd=inputs.fgd, onsets=inputs.onsets
    )
    rows = average(results)
    version = inputs.fgd.version if inputs.fgd else None
    part = f"fold {first['fold']}" if first["variant"] == "si" else f"subject {first['subject']}"
    title = (
        f"{ds.path.name}, {first['variant'].upper()} {part}, {split}: mean over subjects "
        f"({fgd_label(inputs.fgd)})"
    )
    notes = [*([inputs.fgd_note] if inputs.fgd_note else []), *not_computable(results)]
    screen = console or Console()
    screen.print(rich_table(rows, title))
    for line in notes:
        screen.print(f"note: {line}", highlight=False, soft_wrap=True)
    if out is not None:
        text = to_csv(rows, version) if Path(out).suffix == ".csv" else to_markdown(rows, title)
        with output_errors(out, "the comparison table"):
            write_bytes_atomic(out, text.encode("utf-8"))
    return {
        "split": split,
        "dataset": str(ds.path.resolve()),
        "fgd_version": version,
        "systems": rows,
        "notes": notes,
    }


def _cells(row: dict[str, float | None]) -> list[str]:
    values = [(row.get(k), scale, fmt) for k, _, scale, fmt in COLUMNS]
    return ["n/a" if v is None else fmt.format(v * scale) for v, scale, fmt in values]


def rich_table(rows: dict[str, dict[str, float | None]], title: str) -> Table:
    """One row per system (models first, then the baselines)."""
    t = Table(title=title)
    t.add_column("System", no_wrap=True)
    for _, header, _, _ in COLUMNS:
        t.add_column(header, justify="right")
    for name, row in rows.items():
        t.add_row(name, *_cells(row))
    return t


def to_csv(rows: dict[str, dict[str, float | None]], fgd_version: str | None) -> str:
    """system, every column key (full precision, empty where not computable), fgd_version."""
    text = io.StringIO(newline="")
    w = csv.writer(text)
    w.writerow(["system", *(k for k, *_ in COLUMNS), "fgd_version"])
    for name, row in rows.items():
        values = [row.get(k) for k, *_ in COLUMNS]
        w.writerow(
            [name, *("" if v is None else repr(float(v)) for v in values), fgd_version or ""]
        )
    return text.getvalue()


def to_markdown(rows: dict[str, dict[str, float | None]], title: str) -> str:
    """A Markdown table with the printed precision, titled."""
    head = ["System", *(h for _, h, _, _ in COLUMNS)]
    lines = [f"**{title}**", "", "| " + " | ".join(head) + " |"]
    lines.append("|" + "|".join(["---"] + ["---:"] * len(COLUMNS)) + "|")
    lines += ["| " + " | ".join([name, *_cells(row)]) + " |" for name, row in rows.items()]
    return "\n".join(lines) + "\n"
