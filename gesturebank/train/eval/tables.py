"""`evaluate`'s tables, as data: Table 5.1's and the seeds' and the field's cells (drawn on the
terminal by `app.eval_table`), the reasons a cell is n/a (footnotes, each said once), and the
plain verdict when a scored system is worse than predicting the mean pose."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from gesturebank.train.eval.evaluate import (
    EVERY,
    GROUP_KEYS,
    MEAN_POSE,
    NATURAL,
    SHIFTED,
    SHUFFLED,
    Column,
    average,
)


def units(columns: Sequence[Column]) -> str:
    """'units: RMSE °, ΔJ̃ 10⁵ rad²s⁻⁵': the units a narrow table's short headers leave out."""
    named = [f"{c.header.split(' (')[0]} {c.unit}" for c in columns if c.unit]
    return f"units: {', '.join(named)}" if named else ""


WORSE = "✗"  # beside a system worse than the mean pose
WORSE_LEGEND = f"{WORSE} worse than the mean-pose baseline (RMSE): predicting no motion beats it"


def worse_than_mean_pose(
    results: dict[str, dict[str, dict[str, Any]]],
) -> dict[str, tuple[float, float]]:
    """The scored systems (not the baselines) whose average RMSE is above the mean pose's:
    {system: (its RMSE, the mean pose's), degrees}."""
    avg = average(results)
    base = avg.get(MEAN_POSE, {}).get("rmse_deg")
    if base is None:
        return {}
    baselines = {NATURAL, MEAN_POSE, SHUFFLED, SHIFTED}
    return {
        system: (rmse, base)
        for system, row in avg.items()
        if system not in baselines and (rmse := row.get("rmse_deg")) is not None and rmse > base
    }


def worse_lines(results: dict[str, dict[str, dict[str, Any]]]) -> list[str]:
    """One plain sentence per system worse than the mean pose (`evaluate`'s last lines)."""
    return [
        f"{system} is worse than the mean-pose baseline: RMSE {rmse:.2f}° against {base:.2f}°; "
        "it has not learned this motion (more data, more epochs or another model)"
        for system, (rmse, base) in worse_than_mean_pose(results).items()
    ]


def not_computable(results: dict[str, dict[str, dict[str, Any]]]) -> list[str]:
    """One line per subject and system with measures that could not be computed, and why."""
    return [
        f"{subject}, {system}: {group} not computable — {reason}"
        for subject, systems in results.items()
        for system, row in systems.items()
        for group, reason in row["not_computable"].items()
    ]


SUPERSCRIPTS = "¹²³⁴⁵⁶⁷⁸⁹"


@dataclass(frozen=True)
class Footnotes:
    """Why cells are n/a, each reason said once: a mark per group of measures, and its line.

    `groups[(subject, system)]` are the groups not computable there; `absent` maps a measure
    that no row has (FGD without an autoencoder) to its mark.
    """

    marks: dict[str, str]  # group (or absent measure) → superscript
    groups: dict[tuple[str, str], tuple[str, ...]]
    lines: list[str]

    def mark(self, system: str, key: str, subject: str | None = None) -> str:
        """The marks of the reasons `key` is n/a for `system` (of `subject`, else any)."""
        if key in self.marks:  # a measure no row has
            return self.marks[key]
        found = {
            g
            for (subj, sys_), groups in self.groups.items()
            if sys_ == system and subject in (None, subj)
            for g in groups
            if g == EVERY or key in GROUP_KEYS.get(g, ())
        }
        return "".join(m for g, m in self.marks.items() if g in found)


def footnotes(
    results: dict[str, dict[str, dict[str, Any]]], absent: dict[str, str] | None = None
) -> Footnotes:
    """The n/a reasons of `results` ({subject → {system → metrics}}), one line per group:
    '¹ LCCA, CCA, FCCA not computable: REASON — s0: every system; s1: MLP' (distinct reasons
    of a group joined by ' · '). `absent` maps a
    measure missing from every row to why (one line each)."""
    by_group: dict[str, dict[str, list[tuple[str, str]]]] = {}
    groups: dict[tuple[str, str], tuple[str, ...]] = {}
    for subject, systems in results.items():
        for system, row in systems.items():
            groups[(subject, system)] = tuple(row["not_computable"])
            for group, reason in row["not_computable"].items():
                by_group.setdefault(group, {}).setdefault(reason, []).append((subject, system))
    marks: dict[str, str] = {}
    lines: list[str] = []
    for group, reasons in by_group.items():
        marks[group] = SUPERSCRIPTS[len(marks) % len(SUPERSCRIPTS)]
        said = " · ".join(f"{reason} — {_who(where, results)}" for reason, where in reasons.items())
        lines.append(f"{marks[group]} {group} not computable: {said}")
    for key, reason in (absent or {}).items():
        marks[key] = SUPERSCRIPTS[len(marks) % len(SUPERSCRIPTS)]
        lines.append(f"{marks[key]} {reason}")
    return Footnotes(marks, groups, lines)


def _who(where: list[tuple[str, str]], results: dict[str, dict[str, dict[str, Any]]]) -> str:
    """'every subject and system', 'MLP, mean pose of every subject', or per subject
    's0: every system; s1: MLP'."""
    subjects: dict[str, list[str]] = {}
    for subject, system in where:
        subjects.setdefault(subject, []).append(system)
    whole = {s for s, systems in subjects.items() if len(systems) == len(results[s])}
    if whole == set(results):
        return "every subject and system"
    if set(subjects) == set(results) and len({tuple(v) for v in subjects.values()}) == 1:
        return f"{', '.join(next(iter(subjects.values())))} of every subject"
    return "; ".join(
        f"{s}: {'every system' if s in whole else ', '.join(systems)}"
        for s, systems in subjects.items()
    )


def cell(value: Any, column: Column, *, mark: str) -> str:
    """A formatted measure, or 'n/a' with the marks of its reasons."""
    if value is None:
        return f"n/a{mark}"
    return column.fmt.format(value * column.scale)
