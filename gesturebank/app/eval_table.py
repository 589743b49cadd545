"""`evaluate`'s tables on the terminal: the scores of `train.eval` as a rich table like
Table 5.1 (the cells, footnotes and verdicts are `train.eval.tables`')."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rich import box
from rich.table import Table

from gesturebank.train.eval.evaluate import TABLE_5_1, Column, average
from gesturebank.train.eval.tables import WORSE, Footnotes, cell, footnotes, worse_than_mean_pose


def table(
    results: dict[str, dict[str, dict[str, Any]]],
    *,
    title: str,
    columns: Sequence[Column] = TABLE_5_1,
    notes: Footnotes | None = None,
    narrow: bool = False,
) -> Table:
    """A rich table like Table 5.1: one row per subject and system, then the averages.

    Headers carry the better-direction (`LEGEND`); n/a cells the marks of `notes`; a system
    worse than the mean pose on average is marked `WORSE` in every row. `narrow`
    (an 80-column terminal): headers without units (`units` says them), no vertical rules."""
    notes = notes or footnotes(results)
    worse = worse_than_mean_pose(results)
    if narrow:
        t = Table(title=title, box=box.SIMPLE_HEAD, pad_edge=False, collapse_padding=True)
    else:
        t = Table(title=title)
    t.add_column("Subject", no_wrap=True)
    t.add_column("System", no_wrap=True)
    for c in columns:
        t.add_column(c.short if narrow else c.title, justify="right", no_wrap=narrow)

    def cells(system: str, row: dict[str, Any], subject: str | None) -> list[str]:
        return [cell(row.get(c.key), c, mark=notes.mark(system, c.key, subject)) for c in columns]

    def name(system: str) -> str:
        return f"{system} [red]{WORSE}[/red]" if system in worse else system

    for subject, systems in results.items():
        for i, (system, row) in enumerate(systems.items()):
            t.add_row(subject if i == 0 else "", name(system), *cells(system, row, subject))
        t.add_section()
    for i, (system, row) in enumerate(average(results).items()):
        first = "[bold]average[/bold]" if i == 0 else ""
        t.add_row(first, name(system), *cells(system, row, None))
    return t
