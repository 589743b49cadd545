"""QC verdicts: absolute thresholds on each clip's metrics plus dataset-relative outliers.

Pure functions over metrics (`qc.clip_metrics.ClipMetrics`). A clip is `rejected` when any
check fails; each failed check adds one reason with its numbers (degrees and seconds in the
text). Rejected clips stay in the dataset, flagged, so they can be looked at (the dashboard,
`report`) and re-admitted by changing the thresholds.

What is stored is judged as well as what was measured: the processed angles' steps (the speed
invariant, `qc.invariants`), their jerk (the jerk invariant and the relative check on `jerk`)
and a robot frozen at a limit while the person moves (`frozen_at_limit_s`). Motion beyond the
robot's reach is reported, not judged, unless `max_limit_fraction` is set.

Relative check (as Fig. 4.7, where one subject's failed 3D pose stands out): for each of
`outlier_metrics` the robust z-score of log(metric) over the dataset's clips,
z = (log m − median) / (1.4826 · MAD). A clip is an outlier when z > `outlier_z` and its metric is
also more than `outlier_min_ratio` × the dataset median (so a dataset of near-identical clips
with a tiny MAD does not reject ordinary variation). Needs `outlier_min_clips` clips.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from typing import Literal, NamedTuple

import numpy as np

from gesturebank.config import QCConfig
from gesturebank.qc.clip_metrics import ClipMetrics, number
from gesturebank.qc.invariants import invariant_reasons
from gesturebank.qc.table import CHECKS, Check, Scope, by_metric

Verdict = tuple[Literal["accepted", "rejected"], list[str]]


class _ThresholdView(Mapping[str, tuple[str, Literal["max", "min"]]]):
    """`THRESHOLDS`, kept equal to the table as checks are added."""

    def _items(self) -> dict[str, tuple[str, Literal["max", "min"]]]:
        return {c.metric: (c.field, c.side) for c in CHECKS if c.field is not None}

    def __getitem__(self, key: str) -> tuple[str, Literal["max", "min"]]:
        return self._items()[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._items())

    def __len__(self) -> int:
        return len(self._items())


# A clip whose head and both arms were each unseen too long (clips.max_part_unseen_fraction):
# every part masked (issue 32: parts are judged on their own, the clip keeps those seen).
NO_PART = (
    "no body part seen: head, left arm and right arm each unseen in more than "
    "clips.max_part_unseen_fraction of the clip"
)

LABELS = {"jerk_raw": "raw jerk", "jerk": "processed jerk"}  # in the outlier reasons

# The absolute checks by metric: metric → (QCConfig field, "max" | "min"), read from the one
# table of checks (`qc.table.CHECKS`); a field that is None (max_jerk_raw by default) is no check.
THRESHOLDS: Mapping[str, tuple[str, Literal["max", "min"]]] = _ThresholdView()


class Failure(NamedTuple):
    """One failed check of a clip: the check (None for the whole-clip rules outside the table:
    no part seen, the invariants, the dataset-relative outliers) and its reason."""

    check: Check | None
    reason: str

    @property
    def scope(self) -> Scope:
        return "take" if self.check is None else self.check.scope


def threshold(key: str, config: QCConfig) -> tuple[Literal["max", "min"], float] | None:
    """("max" | "min", limit) of the absolute check on metric `key`; None when it has none."""
    check = by_metric(key)
    limit = None if check is None else check.limit(config)
    return None if check is None or limit is None else (check.side, limit)


def fails(key: str, value: float | None, *, config: QCConfig) -> bool:
    """Whether metric `key` at `value` fails its absolute check (NaN and None fail nothing)."""
    check = by_metric(key)
    return check is not None and check.fails(value, config)


def is_outlier_reason(key: str, reason: str) -> bool:
    """Whether `reason` is the dataset-relative outlier reason of metric `key`."""
    return reason.startswith(f"{LABELS.get(key, key)} ") and "× dataset median" in reason


def failures(metrics: ClipMetrics, config: QCConfig) -> list[Failure]:
    """The absolute checks one clip's metrics fail (`qc.table.CHECKS`, in its order, then the
    invariants); NaN metrics are not measured and fail nothing."""
    m = metrics
    out = []
    parts = (m.head_unknown_fraction, m.left_arm_unknown_fraction, m.right_arm_unknown_fraction)
    if all(number(p) >= 1.0 for p in parts):  # every part masked: nothing left to learn from
        out.append(Failure(None, NO_PART))
    for check in CHECKS:
        value = m.value(check.metric)
        if check.fails(value, config):
            out.append(Failure(check, check.text(value, m, config)))
    return out + [Failure(None, r) for r in invariant_reasons(m.invariants, config)]


def absolute_reasons(metrics: ClipMetrics, config: QCConfig) -> list[str]:
    """Reasons (empty when none) of the absolute checks on one clip's metrics (`failures`)."""
    return [f.reason for f in failures(metrics, config)]


def robust_z(values: np.ndarray) -> tuple[np.ndarray, float]:
    """Robust z-scores `(n,)` of `values (n,)` (median / 1.4826·MAD; NaN stays NaN) and the
    median. With MAD = 0 the z-score is ±inf off the median and 0 on it."""
    v = np.asarray(values, dtype=np.float64)
    finite = v[np.isfinite(v)]
    if not len(finite):
        return np.full_like(v, np.nan), math.nan
    med = float(np.median(finite))
    mad = 1.4826 * float(np.median(np.abs(finite - med)))
    with np.errstate(divide="ignore", invalid="ignore"):
        z = (v - med) / mad if mad > 0 else np.where(v == med, 0.0, np.sign(v - med) * np.inf)
    return z, med


def relative_reasons(
    metrics_by_clip: Mapping[str, ClipMetrics], config: QCConfig
) -> dict[str, list[str]]:
    """Dataset-relative outlier reasons per clip id (see the module docstring)."""
    ids = list(metrics_by_clip)
    out: dict[str, list[str]] = {i: [] for i in ids}
    if len(ids) < config.outlier_min_clips:
        return out
    for key in config.outlier_metrics:
        values = np.array([metrics_by_clip[i].value(key) for i in ids])
        with np.errstate(divide="ignore", invalid="ignore"):
            logs = np.where(values > 0, np.log(values), np.nan)
        z, med_log = robust_z(logs)
        if not np.isfinite(med_log):
            continue
        ratio = values / math.exp(med_log)
        for i, zi, ri in zip(ids, z, ratio, strict=True):
            if zi > config.outlier_z and ri > config.outlier_min_ratio:
                label = LABELS.get(key, key)
                out[i].append(f"{label} {ri:.1f}× dataset median (robust z {zi:.1f})")
    return out


def verdicts(
    metrics_by_clip: Mapping[str, ClipMetrics], config: QCConfig | None = None
) -> dict[str, Verdict]:
    """(status, reasons) per clip id: "rejected" with every failed check's reason, else
    "accepted". `metrics_by_clip` holds the clips of one dataset."""
    c = config or QCConfig()
    relative = relative_reasons(metrics_by_clip, c)
    result: dict[str, Verdict] = {}
    for clip_id, metrics in metrics_by_clip.items():
        reasons = absolute_reasons(metrics, c) + relative[clip_id]
        result[clip_id] = ("rejected" if reasons else "accepted", reasons)
    return result
