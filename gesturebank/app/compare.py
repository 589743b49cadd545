"""`gesturebank compare`: several trained models and the baselines on one split, one table.

Every model is scored as `evaluate` scores it (its own post-processing, then the same measures
on the same segments), with one scoring config for all and one FGD autoencoder; a row is the
mean over subjects (Table 5.1's averaging). The table is printed and, with `out`, written as
CSV (`.csv`) or Markdown (`.md`) (`train.eval.compare`); both carry the FGD version.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from rich import box
from rich.console import Console
from rich.table import Table

from gesturebank.app import NARROW_COLUMNS
from gesturebank.config import TrainConfig
from gesturebank.errors import InputError
from gesturebank.fileio import output_errors, write_bytes_atomic
from gesturebank.train import model_folder
from gesturebank.train.eval.compare import (
    COLUMNS,
    FORMATS,
    PathLike,
    model_names,
    to_csv,
    to_markdown,
)
from gesturebank.train.eval.evaluate import (
    LEGEND,
    Column,
    average,
    baselines,
    postprocess,
    score_systems,
)
from gesturebank.train.eval.fgd import label as fgd_label
from gesturebank.train.eval.field import prepare_trained
from gesturebank.train.eval.tables import Footnotes, cell, footnotes, units
from gesturebank.train.torch_runtime import predict as torch_predict
from gesturebank.train.torch_runtime import torch_settings


def compare_command(
    model_dirs: Sequence[PathLike],
    *,
    dataset: PathLike | None = None,
    split: str = "test",
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
    for f in folders[1:]:
        trained_on = (f.info.variant, f.info.fold, f.info.subject)
        if trained_on != (first.variant, first.fold, first.subject) or (
            dataset is None and f.info.dataset != first.dataset
        ):
            raise InputError(
                f"{f.path}: trained on another split or dataset than {folders[0].path}; "
                "compare scores models of one split"
            )
    cfg = config or folders[0].train_config
    ds, inputs = prepare_trained(folders[0], dataset, part=split, config=cfg)
    variant: str = first.need(folders[0].path, "variant")
    segments = inputs.segments
    rate_hz = float(ds.info.rates.pose_hz)
    systems: dict[str, list[np.ndarray]] = {}
    for name, folder in zip(model_names([f.path for f in folders]), folders, strict=True):
        own = folder.train_config
        net = folder.torch_model()
        with torch_settings(own.seed, own.threads):
            pred01 = [torch_predict(net, s.audio) for s in segments]
        systems[name] = [
            postprocess(p, folder.profile, rate_hz=rate_hz, config=own) for p in pred01
        ]
    systems |= baselines(
        segments,
        mean_pose01=np.asarray(folders[0].norm["mean_pose01"]),
        profile=folders[0].profile,
        rate_hz=rate_hz,
        config=cfg,
        donors=inputs.donors,
    )
    results = score_systems(
        segments,
        systems,
        profile=folders[0].profile,
        rate_hz=rate_hz,
        config=cfg,
        fgd=inputs.fgd,
        onsets=inputs.onsets,
    )
    rows = average(results)
    version = inputs.fgd.version if inputs.fgd else None
    part = f"fold {first.fold}" if variant == "si" else f"subject {first.subject}"
    title = (
        f"{ds.path.name}, {variant.upper()} {part}, {split}: mean over subjects "
        f"({fgd_label(inputs.fgd)})"
    )
    notes = footnotes(results, {"fgd": inputs.fgd_note} if inputs.fgd_note else None)
    screen = console or Console()
    narrow = screen.width < NARROW_COLUMNS  # two tables of short headers, units below
    if narrow:
        half = len(COLUMNS) // 2  # errors and correlations, then the motion's statistics
        for part_title, columns in ((title, COLUMNS[:half]), (None, COLUMNS[half:])):
            screen.print(
                rich_table(rows, title=part_title, notes=notes, columns=columns, narrow=True)
            )
    else:
        screen.print(rich_table(rows, title=title, notes=notes))
    legend = [LEGEND, units(COLUMNS)] if narrow else [LEGEND]
    for line in [*legend, *notes.lines]:  # narrow: wrapped at words, each note whole
        screen.print(line, highlight=False, soft_wrap=not narrow)
    if out is not None:
        text = (
            to_csv(rows, version)
            if Path(out).suffix == ".csv"
            else to_markdown(rows, title=title, notes=notes)
        )
        with output_errors(out, "the comparison table"):
            write_bytes_atomic(out, text.encode("utf-8"))
    return {
        "split": split,
        "dataset": str(ds.path.resolve()),
        "fgd_version": version,
        "systems": rows,
        "notes": notes.lines,
    }


def rich_table(
    rows: dict[str, dict[str, float | None]],
    *,
    title: str | None,
    notes: Footnotes | None = None,
    columns: Sequence[Column] = COLUMNS,
    narrow: bool = False,
) -> Table:
    """One row per system (models first, then the baselines); headers with ↑/↓/≈ (`LEGEND`),
    n/a cells with the marks of `notes`. `narrow` (an 80-column terminal): headers without
    units (`units` says them), no vertical rules."""
    notes = notes or Footnotes({}, {}, [])
    if narrow:
        t = Table(title=title, box=box.SIMPLE_HEAD, pad_edge=False, collapse_padding=True)
    else:
        t = Table(title=title)
    t.add_column("System", no_wrap=True)
    for c in columns:
        t.add_column(c.short if narrow else c.title, justify="right", no_wrap=narrow)
    for name, row in rows.items():
        t.add_row(name, *(cell(row.get(c.key), c, mark=notes.mark(name, c.key)) for c in columns))
    return t
