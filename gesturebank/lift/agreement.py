"""Agreement of a measuring instrument with the truth: bias, 95 % limits of agreement, ICC(2,1),
each with a bootstrap interval over clips.

The build measures a person's motion the way a clinical instrument measures a quantity, and is
reported the same way (benchmarks/fidelity.py, issue 39):

- **bias** and **95 % limits of agreement** (Bland & Altman 1986): the differences d = measured −
  truth have mean `bias` and standard deviation s (n − 1); 95 % of single readings fall within
  bias ± 1.96 s;
- **ICC(2,1)** (Shrout & Fleiss 1979, "case 2": targets and raters random, one reading, absolute
  agreement): the instrument and the truth are the two raters, each frame a target, so a constant
  offset lowers it as much as noise does;
- a **bootstrap over clips**: frames of one clip are not independent (a pose holds for many
  frames), so the intervals resample whole clips with replacement and recompute the statistic
  on their frames pooled (percentile intervals).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

Z_95 = 1.959963984540054  # Φ⁻¹(0.975): 95 % of a normal distribution lies within ±Z_95 σ


@dataclass(frozen=True)
class Interval:
    """A statistic over all clips (`value`) and its bootstrap interval [`low`, `high`]."""

    value: float
    low: float
    high: float

    def text(self, digits: int = 1) -> str:
        """'value [low, high]'."""
        return f"{self.value:.{digits}f} [{self.low:.{digits}f}, {self.high:.{digits}f}]"


@dataclass(frozen=True)
class LimitsOfAgreement:
    """Bland-Altman: mean difference and the 95 % limits of agreement bias ± 1.96 s."""

    bias: float
    lower: float
    upper: float


def _pairs(measured: np.ndarray, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The readings `(n,)` known on both sides, as float64."""
    m = np.asarray(measured, np.float64).ravel()
    t = np.asarray(truth, np.float64).ravel()
    if m.shape != t.shape:
        raise ValueError(f"measured {m.shape} and truth {t.shape} differ")
    known = np.isfinite(m) & np.isfinite(t)
    return m[known], t[known]


def limits_of_agreement(*, measured: np.ndarray, truth: np.ndarray) -> LimitsOfAgreement:
    """Bland-Altman bias and 95 % limits of `measured` against `truth` (same shape; NaN pairs
    left out); NaN with fewer than 2 pairs."""
    m, t = _pairs(measured, truth)
    if len(m) < 2:
        return LimitsOfAgreement(np.nan, np.nan, np.nan)
    d = m - t
    bias, spread = float(d.mean()), float(d.std(ddof=1))
    return LimitsOfAgreement(bias, bias - Z_95 * spread, bias + Z_95 * spread)


def icc_2_1(ratings: np.ndarray) -> float:
    """ICC(2,1) of `ratings (n targets, k raters)` (rows with a NaN left out): two-way random
    effects, absolute agreement, single rater (Shrout & Fleiss 1979),

        (MSR − MSE) / (MSR + (k − 1) MSE + k (MSC − MSE) / n),

    MSR, MSC, MSE the mean squares of the rows (targets), columns (raters) and residual of a
    two-way ANOVA. NaN with fewer than 2 targets or no variance at all."""
    x = np.asarray(ratings, np.float64)
    if x.ndim != 2 or x.shape[1] < 2:
        raise ValueError(f"ratings must be (targets, raters ≥ 2), got {x.shape}")
    x = x[np.isfinite(x).all(axis=1)]
    n, k = x.shape
    if n < 2:
        return float("nan")
    grand = x.mean()
    ss_rows = k * float(((x.mean(axis=1) - grand) ** 2).sum())
    ss_cols = n * float(((x.mean(axis=0) - grand) ** 2).sum())
    ss_error = float(((x - grand) ** 2).sum()) - ss_rows - ss_cols
    msr, msc = ss_rows / (n - 1), ss_cols / (k - 1)
    mse = ss_error / ((n - 1) * (k - 1))
    denominator = msr + (k - 1) * mse + k * (msc - mse) / n
    return float((msr - mse) / denominator) if denominator > 0 else float("nan")


def icc_agreement(*, measured: np.ndarray, truth: np.ndarray) -> float:
    """ICC(2,1) of an instrument against the truth: the two as raters, each reading a target."""
    m, t = _pairs(measured, truth)
    return icc_2_1(np.stack([m, t], axis=1))


Statistic = Callable[[np.ndarray, np.ndarray], float]


def bootstrap_over_clips(
    clips: Sequence[tuple[np.ndarray, np.ndarray]],
    statistic: Statistic,
    *,
    draws: int = 1000,
    level: float = 0.95,
    seed: int = 0,
) -> Interval:
    """`statistic(measured, truth)` over the frames of all `clips` ((measured, truth) arrays of
    one clip each, same shape), and its percentile bootstrap interval at `level`: each draw
    takes len(clips) clips with replacement and pools their frames. A single clip gives no
    interval (NaN bounds): its frames are one sample, not many."""
    if not clips:
        return Interval(np.nan, np.nan, np.nan)
    measured = [np.asarray(m, np.float64) for m, _ in clips]
    truth = [np.asarray(t, np.float64) for _, t in clips]
    value = statistic(np.concatenate(measured), np.concatenate(truth))
    if len(clips) < 2:
        return Interval(value, np.nan, np.nan)
    rng = np.random.default_rng(seed)
    stats = np.empty(draws)
    for i in range(draws):
        pick = rng.integers(0, len(clips), len(clips))
        stats[i] = statistic(
            np.concatenate([measured[j] for j in pick]), np.concatenate([truth[j] for j in pick])
        )
    stats = stats[np.isfinite(stats)]
    if not len(stats):
        return Interval(value, np.nan, np.nan)
    tail = 100 * (1 - level) / 2
    low, high = np.percentile(stats, [tail, 100 - tail])
    return Interval(value, float(low), float(high))


def bias(measured: np.ndarray, truth: np.ndarray) -> float:
    """Mean of measured − truth (a `Statistic`)."""
    return limits_of_agreement(measured=measured, truth=truth).bias


def lower_limit(measured: np.ndarray, truth: np.ndarray) -> float:
    """The lower 95 % limit of agreement (a `Statistic`)."""
    return limits_of_agreement(measured=measured, truth=truth).lower


def upper_limit(measured: np.ndarray, truth: np.ndarray) -> float:
    """The upper 95 % limit of agreement (a `Statistic`)."""
    return limits_of_agreement(measured=measured, truth=truth).upper


def icc(measured: np.ndarray, truth: np.ndarray) -> float:
    """ICC(2,1) against the truth (a `Statistic`)."""
    return icc_agreement(measured=measured, truth=truth)


def mean_absolute(measured: np.ndarray, truth: np.ndarray) -> float:
    """Mean |measured − truth| (a `Statistic`)."""
    m, t = _pairs(measured, truth)
    return float(np.abs(m - t).mean()) if len(m) else float("nan")


@dataclass(frozen=True)
class Agreement:
    """One quantity's agreement with the truth over clips, each with its bootstrap interval."""

    bias: Interval
    lower: Interval
    upper: Interval
    icc: Interval
    mae: Interval
    clips: int
    readings: int


def agreement(
    clips: Sequence[tuple[np.ndarray, np.ndarray]], *, draws: int = 1000, seed: int = 0
) -> Agreement:
    """Bias, limits of agreement, ICC(2,1) and mean absolute error of one quantity over `clips`
    ((measured, truth) per clip), each with a bootstrap interval over clips (same draws: one
    seed)."""

    def boot(statistic: Statistic) -> Interval:
        return bootstrap_over_clips(clips, statistic, draws=draws, seed=seed)

    readings = sum(len(_pairs(m, t)[0]) for m, t in clips)
    return Agreement(
        bias=boot(bias),
        lower=boot(lower_limit),
        upper=boot(upper_limit),
        icc=boot(icc),
        mae=boot(mean_absolute),
        clips=len(clips),
        readings=readings,
    )
