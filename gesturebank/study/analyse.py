"""The study's results as the dissertation reported them (seed 000 §5.2, seed 002's MUSHRA).

Per rating question: each condition's (model's, the hidden reference's, the anchor's) mean
rating over every submitted rating with a 95 % t confidence interval, clipped to the rating
scale (0–100: no mean can lie outside it); and for each pair of conditions a paired test over
the pages where one participant rated both — the paired t-test when there are at least
`NORMAL_MIN_N` differences and Shapiro–Wilk does not reject their normality (p > 0.05), else
the Wilcoxon signed-rank test (ratings are bounded, often skewed). Per A/B pair of models: the
share of choices for each and a two-sided binomial test against 50 %.

Several pairs are tested at once, so each family (one question's pairwise tests; the A/B
pairs) also gets Holm's step-down adjusted p (Holm 1979), printed beside the raw p: sorted
ascending, p₍ᵢ₎ × (m − i + 1), made non-decreasing, capped at 1.

Only participants who finished count by default (`include_partial` adds those who stopped
half-way); each answer is stored once.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field
from itertools import combinations
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

from gesturebank.errors import InputError
from gesturebank.study import db
from gesturebank.study.design import Design, load_design

NORMAL_MIN_N = 8  # fewer paired differences: no normality test, Wilcoxon
SCALE = (0.0, 100.0)  # the rating sliders' range (the app accepts integers 0–100 only)
ANALYSIS_DIR, PLOT = "analysis", "ratings.png"


@dataclass
class Analysis:
    ratings: list[dict[str, Any]] = field(default_factory=list)  # question, condition, n, mean, ci
    tests: list[dict[str, Any]] = field(default_factory=list)  # question, a, b, n, test, p, p_holm
    preferences: list[dict[str, Any]] = field(default_factory=list)  # a, b, n, wins_a, share_a, p…
    participants: int = 0  # whose answers were analysed
    finished: int = 0
    partial: int = 0  # answered some pages, not all
    no_answer: int = 0  # consented, answered nothing
    include_partial: bool = False
    plot: Path | None = None


def mean_ci(
    *, values: np.ndarray, level: float = 0.95, scale: tuple[float, float] | None = None
) -> tuple[float, float, float]:
    """Mean and the t confidence interval of the mean (NaN bounds for one value), clipped to
    `scale` (low, high) when given: a bounded rating's mean cannot lie outside it."""
    n, mean = len(values), float(np.mean(values))
    if n < 2:
        return mean, math.nan, math.nan
    half = float(stats.t.ppf(0.5 + level / 2, n - 1) * np.std(values, ddof=1) / math.sqrt(n))
    low, high = mean - half, mean + half
    if scale is not None:
        low, high = max(low, scale[0]), min(high, scale[1])
    return mean, low, high


def holm(p_values: np.ndarray) -> np.ndarray:
    """Holm's step-down adjusted p of one family of tests (module docstring); NaN (no test)
    stays NaN and does not count towards the family's size."""
    p = np.asarray(p_values, dtype=np.float64)
    adjusted = np.full_like(p, np.nan)
    tested = np.flatnonzero(np.isfinite(p))
    order = tested[np.argsort(p[tested], kind="stable")]
    m = len(order)
    running = 0.0
    for i, k in enumerate(order):
        running = max(running, min(1.0, (m - i) * p[k]))
        adjusted[k] = running
    return adjusted


def paired_test(*, a: np.ndarray, b: np.ndarray) -> tuple[str, float, float]:
    """(name, statistic, two-sided p) of the paired test suited to the differences a − b."""
    d = a - b
    if len(d) < 2 or not np.any(d):
        return "none", math.nan, 1.0 if len(d) else math.nan
    if len(d) >= NORMAL_MIN_N and stats.shapiro(d).pvalue > 0.05:
        t = stats.ttest_rel(a, b)
        return "paired t", float(t.statistic), float(t.pvalue)
    w = stats.wilcoxon(a, b)
    return "wilcoxon", float(w.statistic), float(w.pvalue)


def _condition(design: Design, stimulus: str) -> str:
    s = design.stimuli[stimulus]
    return s.model or s.role


def analyse(folder: Path, *, plot: bool = True, include_partial: bool = False) -> Analysis:
    """The tables (and the plot, in `folder/analysis/`) of the answers stored in `folder`:
    of participants who finished, and with `include_partial` of those who stopped too."""
    design = load_design(folder)
    if not (folder / db.DATABASE).is_file():
        raise InputError(f"{folder / db.DATABASE}: no answers yet (run `gesturebank study serve`)")
    with db.connect(folder / db.DATABASE) as con:
        rows = db.all_answers(con)
        counts = db.participant_counts(con)
    if not include_partial:
        rows = [r for r in rows if r["finished"]]
    result = Analysis(
        participants=len({r["participant"] for r in rows}),
        finished=counts["finished"],
        partial=counts["partial"],
        no_answer=counts["no_answer"],
        include_partial=include_partial,
    )
    # ratings[question][condition] → values; paired[question][(participant, trial)][condition]
    ratings: dict[str, dict[str, list[int]]] = defaultdict(lambda: defaultdict(list))
    paired: dict[str, dict[tuple[int, str], dict[str, int]]] = defaultdict(dict)
    chosen: dict[tuple[int, str], dict[str, int]] = defaultdict(dict)
    for r in rows:
        cond = _condition(design, r["stimulus"])
        if r["rating"] is not None:
            ratings[r["question"]][cond].append(r["rating"])
            paired[r["question"]].setdefault((r["participant"], r["trial"]), {})[cond] = r["rating"]
        elif r["chosen"] is not None:
            chosen[(r["participant"], r["trial"])][cond] = r["chosen"]
    for question in sorted(ratings):
        for cond in sorted(ratings[question]):
            values = np.asarray(ratings[question][cond], float)
            mean, lo, hi = mean_ci(values=values, scale=SCALE)
            result.ratings.append(
                {"question": question, "condition": cond, "n": len(values), "mean": mean}
                | {"ci_low": lo, "ci_high": hi}
            )
        family = len(result.tests)
        for a, b in combinations(sorted(ratings[question]), 2):
            pages = [p for p in paired[question].values() if a in p and b in p]
            xa = np.asarray([p[a] for p in pages], float)
            xb = np.asarray([p[b] for p in pages], float)
            name, statistic, p = paired_test(a=xa, b=xb)
            mean_diff = float(np.mean(xa - xb)) if pages else math.nan
            result.tests.append(
                {"question": question, "a": a, "b": b, "n": len(pages), "mean_diff": mean_diff}
                | {"test": name, "statistic": statistic, "p": p}
            )
        tests = result.tests[family:]
        for t, adjusted in zip(tests, holm(np.asarray([t["p"] for t in tests])), strict=True):
            t["p_holm"] = float(adjusted)
    wins: dict[tuple[str, str], list[int]] = defaultdict(list)
    for answer in chosen.values():
        if len(answer) == 2:
            a, b = sorted(answer)
            wins[(a, b)].append(answer[a])
    for (a, b), picks in sorted(wins.items()):
        k, n = int(sum(picks)), len(picks)
        p = float(stats.binomtest(k, n, 0.5).pvalue)
        result.preferences.append({"a": a, "b": b, "n": n, "wins_a": k, "share_a": k / n, "p": p})
    adjusted = holm(np.asarray([p["p"] for p in result.preferences]))
    for pref, p_holm in zip(result.preferences, adjusted, strict=True):
        pref["p_holm"] = float(p_holm)
    if plot and (result.ratings or result.preferences):
        result.plot = write_plot(result, folder / ANALYSIS_DIR / PLOT)
    return result


def write_plot(result: Analysis, path: Path) -> Path:
    """Mean ratings with their 95 % intervals per question, and the A/B shares, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    questions = sorted({r["question"] for r in result.ratings})
    panels = len(questions) + bool(result.preferences)
    fig, axes = plt.subplots(1, panels, figsize=(5 * panels, 4), squeeze=False)
    for ax, question in zip(axes[0], questions, strict=False):
        rows = [r for r in result.ratings if r["question"] == question]
        means = [r["mean"] for r in rows]
        err = [
            [r["mean"] - r["ci_low"] if math.isfinite(r["ci_low"]) else 0 for r in rows],
            [r["ci_high"] - r["mean"] if math.isfinite(r["ci_high"]) else 0 for r in rows],
        ]
        ax.bar([r["condition"] for r in rows], means, yerr=err, capsize=4, color="#6a8caf")
        ax.set_ylim(0, 100)
        ax.set_title(f"{question}: mean rating, 95 % CI")
        ax.tick_params(axis="x", rotation=30)
    if result.preferences:
        ax = axes[0][-1]
        labels = [f"{p['a']} vs {p['b']}" for p in result.preferences]
        shares = [100 * p["share_a"] for p in result.preferences]
        ax.barh(labels, shares, color="#6a8caf")
        ax.barh(labels, [100 - s for s in shares], left=shares, color="#d9a066")
        ax.axvline(50, color="k", lw=1)
        ax.set_xlim(0, 100)
        ax.set_title("A/B: % preferring the first")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
