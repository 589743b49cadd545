"""QC verdicts: absolute thresholds on each take's metrics plus dataset-relative outliers.

A take is `rejected` when any check fails; each failed check adds one reason with its numbers
(degrees and seconds in the text). Rejected takes stay in the dataset, flagged, so they can be
looked at (`qc.dashboard`) and re-admitted by changing the thresholds.

Relative check (as Fig. 4.7, where one subject's failed 3D pose stands out): for each of
`outlier_metrics` the robust z-score of log(metric) over the dataset's built takes,
z = (log m − median) / (1.4826 · MAD). A take is an outlier when z > `outlier_z` and its metric is
also more than `outlier_min_ratio` × the dataset median (so a dataset of near-identical takes
with a tiny MAD does not reject ordinary variation). Needs `outlier_min_takes` takes.
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from gesturebank.config import QCConfig, SplitsConfig
from gesturebank.datasets import store
from gesturebank.datasets.splits import write_splits
from gesturebank.errors import InputError
from gesturebank.qc.metrics import take_metrics
from gesturebank.robot import pepper

log = logging.getLogger(__name__)

Verdict = tuple[store.Status, list[str]]


_LABELS = {"jerk_raw": "raw jerk", "jerk": "processed jerk"}


def _num(metrics: Mapping[str, float], key: str) -> float:
    value = metrics.get(key, float("nan"))
    return float(value) if value is not None else float("nan")


def absolute_reasons(metrics: Mapping[str, float], config: QCConfig) -> list[str]:
    """Reasons (empty when none) of the absolute checks on one take's metrics; NaN metrics are
    not measured and fail nothing."""
    c = config
    m = {k: _num(metrics, k) for k in metrics}
    reasons = []

    def over(key: str, limit: float, text: str) -> None:
        if m.get(key, math.nan) > limit:
            reasons.append(text.format(v=m[key], lim=limit))

    if m.get("duration_s", math.nan) < c.min_duration_s:
        reasons.append(f"too short: {m['duration_s']:.2f} s < {c.min_duration_s:.2f} s")
    over(
        "missing_keypoints_fraction",
        c.max_missing_fraction,
        "keypoints missing or unsure in {v:.0%} of frames (max {lim:.0%})",
    )
    over("keypoint_gap_s", c.max_keypoint_gap_s, "keypoints lost for {v:.2f} s (max {lim:.2f} s)")
    over("bone_cv_max", c.max_bone_cv, "3D bone length varies by {v:.0%} (max {lim:.0%})")
    over(
        "limit_frames_fraction",
        c.max_limit_fraction,
        "a joint clamped at a robot limit in {v:.0%} of frames (max {lim:.0%})",
    )
    over(
        "jitter_fraction",
        c.max_jitter_fraction,
        f"jitter: {{v:.0%}} of raw motion power above {c.jitter_above_hz:g} Hz (max {{lim:.0%}})",
    )
    over("swap_events", c.max_swap_events, "left/right arms swapped {v:.0f}× (max {lim:.0f})")
    over(
        "spike_max", c.max_spike, "keypoint jumps {v:.2f} shoulder widths in one frame (max {lim})"
    )
    over(
        "frozen_fraction",
        c.max_frozen_fraction,
        "pose frozen (exactly repeated) in {v:.0%} of frames (max {lim:.0%})",
    )
    if m.get("motion_range", math.nan) < c.min_motion_range:
        reasons.append(
            f"static: no joint moves more than {np.degrees(m['motion_range']):.1f}° "
            f"(min {np.degrees(c.min_motion_range):.1f}°)"
        )
    if c.max_jerk_raw is not None:
        over("jerk_raw", c.max_jerk_raw, "raw jerk {v:.3g} rad²/s⁵ (max {lim:.3g})")
    return reasons


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
    metrics_by_take: Mapping[str, Mapping[str, float]], config: QCConfig
) -> dict[str, list[str]]:
    """Dataset-relative outlier reasons per take id (see the module docstring)."""
    ids = list(metrics_by_take)
    out: dict[str, list[str]] = {i: [] for i in ids}
    if len(ids) < config.outlier_min_takes:
        return out
    for key in config.outlier_metrics:
        values = np.array([_num(metrics_by_take[i], key) for i in ids])
        with np.errstate(divide="ignore", invalid="ignore"):
            logs = np.where(values > 0, np.log(values), np.nan)
        z, med_log = robust_z(logs)
        if not np.isfinite(med_log):
            continue
        ratio = values / math.exp(med_log)
        for i, zi, ri in zip(ids, z, ratio, strict=True):
            if zi > config.outlier_z and ri > config.outlier_min_ratio:
                label = _LABELS.get(key, key)
                out[i].append(f"{label} {ri:.1f}× dataset median (robust z {zi:.1f})")
    return out


def verdicts(
    metrics_by_take: Mapping[str, Mapping[str, float]], config: QCConfig | None = None
) -> dict[str, Verdict]:
    """(status, reasons) per take id: "rejected" with every failed check's reason, else
    "accepted". `metrics_by_take` holds the built takes of one dataset (`take_metrics` keys)."""
    c = config or QCConfig()
    relative = relative_reasons(metrics_by_take, c)
    result: dict[str, Verdict] = {}
    for take_id, metrics in metrics_by_take.items():
        reasons = absolute_reasons(metrics, c) + relative[take_id]
        result[take_id] = ("rejected" if reasons else "accepted", reasons)
    return result


# --------------------------------------------------------------------------------------------------
# Applying them to a dataset folder


def dataset_profile(out: Path) -> pepper.RobotProfile:
    """The robot profile named in the dataset's dataset.json (the default when absent)."""
    try:
        info = json.loads((Path(out) / store.DATASET_JSON).read_text())
        return pepper.load_profile(str(info.get("robot_profile", pepper.DEFAULT_PROFILE)))
    except (OSError, ValueError, InputError):
        return pepper.load_profile()


def apply_verdicts(
    out: Path, config: QCConfig | None = None, take_ids: Iterable[str] | None = None
) -> dict[str, Verdict]:
    """Measure every built take of the dataset folder `out` (only `take_ids` when given), judge
    them together, and rewrite each take's record (qc_status, qc_reasons, metrics merged into the
    builder's). Failed takes are left alone. Does not touch manifest.parquet (see `run_qc`)."""
    c = config or QCConfig()
    out = Path(out)
    profile = dataset_profile(out)
    wanted = None if take_ids is None else set(take_ids)
    records = [
        r
        for r in store.records(out)
        if r.qc_status != "failed" and (wanted is None or r.take_id in wanted)
    ]
    metrics: dict[str, dict[str, float]] = {}
    for r in records:
        with np.load(store.take_npz(out, r.take_id), allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
        measured = take_metrics(
            arrays,
            profile,
            analysis_rate_hz=c.analysis_rate_hz,
            min_confidence=c.min_confidence,
            jitter_above_hz=c.jitter_above_hz,
        )
        metrics[r.take_id] = {**(r.metrics or {}), **measured}
    result = verdicts(metrics, c)
    for r in records:
        status, reasons = result[r.take_id]
        fields: dict[str, Any] = {
            **r.to_json_dict(),
            "qc_status": status,
            "qc_reasons": reasons,
            "metrics": metrics[r.take_id],
        }
        store.write_record(out, store.TakeRecord.from_json_dict(fields))
    return result


def run_qc(
    out: Path, config: QCConfig | None = None, splits: SplitsConfig | None = None
) -> dict[str, Verdict]:
    """Re-run the QC on a built dataset: records, manifest.parquet, the status counts in
    dataset.json and the splits (verdicts decide who is in them) are rewritten; the takes in
    the manifest stay the same."""
    out = Path(out)
    dataset = store.Dataset(out)
    ids = [r["take_id"] for r in dataset.records()]
    result = apply_verdicts(out, config, ids)
    table = store.write_manifest(out, ids)
    statuses = table.column("qc_status").to_pylist()
    info = {k: v for k, v in dataset.info.items() if k != "schema_version"}
    info["takes"] = {s: statuses.count(s) for s in store.STATUSES}
    store.write_dataset_json(out, info)
    write_splits(out, table.to_pylist(), splits)
    return result
