"""Evaluation of predicted motion per subject, with baselines, as in Table 5.1 of the dissertation.

For every test segment the model's normalised output is turned into angles as in synthesis
(ν⁻¹, then the Butterworth post-smoothing of §4.4.1, then clamping to the limits) and compared
with the ground truth. Two baselines are scored the same way in every evaluation:
- "mean pose": the static mean of the training targets (no motion at all);
- "shifted truth": the ground truth itself, `shift_baseline_s` late (real motion, wrong timing);
  it is undefined for the first frames and after unknown ones, which its scores leave out.

Per subject: L, RMSE and APE pool all frames where truth and prediction are known; the sequence
measures (CCA, FCCA, local CCA, jerkiness, speed histograms) run over the contiguous stretches
where both whole poses are known (≥ 4 frames); local CCA pools the windows of all stretches
(Eq. 3.18), J̃ and ΔJ̃ average over stretches (Eq. 3.22). The table's average row is the mean
over subjects.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from rich.table import Table

from gesturebank.config import TrainConfig
from gesturebank.datasets.torch import Segment
from gesturebank.filters import butter_lowpass
from gesturebank.robot import pepper
from gesturebank.train import metrics as M

MIN_RUN = 4  # frames: the shortest stretch jerkiness is defined on
MEAN_POSE = "mean pose"
SHIFTED = "shifted truth"

Column = tuple[str, str, float, str]  # key, header, scale, format
# The columns of Table 5.1, and a second table with the other seeds' measures.
TABLE_5_1: tuple[Column, ...] = (
    ("loss_l", "Loss L", 1.0, "{:.4f}"),
    ("rmse_deg", "RMSE (°)", 1.0, "{:.2f}"),
    ("delta_lcca", "ΔLCCA", 1.0, "{:.3f}"),
    ("lcca_theta", "LCCA_Θ", 1.0, "{:.4f}"),
    ("delta_jerk", "ΔJ̃ (10⁵ rad²s⁻⁵)", 1e-5, "{:.3f}"),
)
SEED_MEASURES: tuple[Column, ...] = (
    ("cca", "CCA", 1.0, "{:.3f}"),
    ("fcca", "FCCA", 1.0, "{:.3f}"),
    ("ape_deg", "APE (°)", 1.0, "{:.2f}"),
    ("hellinger_speed", "H speed", 1.0, "{:.3f}"),
)


def postprocess(
    pred01: np.ndarray, profile: pepper.RobotProfile, rate_hz: float, config: TrainConfig
) -> np.ndarray:
    """Model output `(N, 11)` in [0, 1] → angles `(N, 11)` rad: ν⁻¹, low-pass (§4.4.1), clamp."""
    angles = pepper.denormalise(pred01, profile)  # ν⁻¹ of Eq. 3.14
    smooth = butter_lowpass(angles, rate_hz, config.smoothing_cutoff_hz, config.smoothing_order)
    return pepper.clamp(smooth, profile)


def shifted_truth(angles: np.ndarray, shift: int) -> np.ndarray:
    """Ground truth `(N, 11)` delayed by `shift` frames: out[t] = angles[t − shift].

    Undefined (NaN) for the first `shift` frames and wherever the source frame is unknown; those
    frames are left out of this baseline's scores.
    """
    a = np.asarray(angles, dtype=np.float32)
    out = np.full_like(a, np.nan)
    if shift < len(a):
        out[shift:] = a[: len(a) - shift]
    return out


def _runs(ok: np.ndarray, min_len: int = MIN_RUN) -> list[tuple[int, int]]:
    """[start, stop) of the runs of True in `ok (N,)` at least `min_len` long."""
    edges = np.diff(np.concatenate([[0], ok.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(int(a), int(b)) for a, b in zip(starts, stops, strict=True) if b - a >= min_len]


def subject_metrics(
    segments: Sequence[Segment],
    predictions: Sequence[np.ndarray],
    profile: pepper.RobotProfile,
    rate_hz: float,
    config: TrainConfig,
) -> dict[str, Any]:
    """Every measure for one subject: segments' ground truth vs `predictions` `(n_k, 11)` rad."""
    pred = np.concatenate(predictions).astype(np.float64)
    true = np.concatenate([s.angles for s in segments]).astype(np.float64)
    true[~np.isfinite(pred)] = np.nan  # score only frames where both are known
    true01 = np.where(np.isfinite(true), pepper.normalise(np.nan_to_num(true), profile), np.nan)
    pred01 = pepper.normalise(pred, profile)
    known = np.isfinite(true)
    per_joint = M.rmse_per_joint(true, pred)
    out: dict[str, Any] = {
        "frames": int(known.any(axis=1).sum()),
        "loss_l": M.loss_l(true01, pred01),  # Eq. 3.15
        "rmse_rad": M.rmse(true, pred),  # Eq. 3.12
        "rmse_per_joint_rad": dict(zip(pepper.JOINTS, per_joint.tolist(), strict=True)),
        "ape_rad": M.ape(true[known], pred[known]),
    }
    window = max(2, round(config.lcca_window_s * rate_hz))
    t_runs, p_runs, a_runs = [], [], []
    for s, p in zip(segments, predictions, strict=True):
        both = np.isfinite(s.angles).all(axis=1) & np.isfinite(p).all(axis=1)
        for a, b in _runs(both):
            t_runs.append(s.angles[a:b].astype(np.float64))
            p_runs.append(np.asarray(p[a:b], dtype=np.float64))
            a_runs.append(s.audio[a:b].astype(np.float64))
    if t_runs:

        def pooled(f: Callable[[np.ndarray, np.ndarray], np.ndarray], xs: list, ys: list) -> float:
            return float(np.mean(np.concatenate([f(x, y) for x, y in zip(xs, ys, strict=True)])))

        def lcca(x: np.ndarray, y: np.ndarray) -> np.ndarray:
            return M.local_cca_values(x, y, window, stride=config.lcca_stride)  # Eq. 3.18

        lcca_at = pooled(lcca, a_runs, t_runs)
        lcca_ap = pooled(lcca, a_runs, p_runs)
        j_mean, dj_mean = M.mean_jerkiness(t_runs, p_runs, rate_hz)  # Eq. 3.22
        h_true = M.speed_histogram(
            np.concatenate([M.speeds(t, rate_hz) for t in t_runs]),
            config.speed_bin,
            config.speed_max,
        )
        h_pred = M.speed_histogram(
            np.concatenate([M.speeds(p, rate_hz) for p in p_runs]),
            config.speed_bin,
            config.speed_max,
        )
        out |= {
            "lcca_theta": pooled(lcca, t_runs, p_runs),  # Eq. 3.19
            "lcca_audio_true": lcca_at,
            "lcca_audio_pred": lcca_ap,
            "delta_lcca": abs(lcca_at - lcca_ap),  # Eq. 3.20
            "cca": float(np.mean([M.cca(t, p) for t, p in zip(t_runs, p_runs, strict=True)])),
            "fcca": float(
                np.mean([M.fcca(t, p, a) for t, p, a in zip(t_runs, p_runs, a_runs, strict=True)])
            ),
            "jerk_pred": j_mean,
            "jerk_true": float(np.mean([M.jerkiness(t, rate_hz) for t in t_runs])),
            "delta_jerk": dj_mean,
            "hellinger_speed": M.hellinger(h_true, h_pred),  # seed 001, Eq. 2
        }
    else:  # no stretch long enough for the sequence measures
        for key in ("lcca_theta", "delta_lcca", "cca", "fcca", "delta_jerk", "hellinger_speed"):
            out[key] = float("nan")
    out["rmse_deg"] = float(np.degrees(out["rmse_rad"]))
    out["ape_deg"] = float(np.degrees(out["ape_rad"]))
    out["rmse_per_joint_deg"] = dict(
        zip(pepper.JOINTS, np.degrees(per_joint).tolist(), strict=True)
    )
    return out


def evaluate_segments(
    segments: Sequence[Segment],
    model_pred01: Sequence[np.ndarray],
    *,
    name: str,
    mean_pose01: np.ndarray,
    profile: pepper.RobotProfile,
    rate_hz: float,
    config: TrainConfig,
) -> dict[str, dict[str, dict[str, Any]]]:
    """{subject → {system → metrics}} for the model (post-processed) and both baselines."""
    mean_pose = pepper.denormalise(np.asarray(mean_pose01)[None], profile)[0]
    shift = round(config.shift_baseline_s * rate_hz)
    systems: dict[str, list[np.ndarray]] = {
        name: [postprocess(p, profile, rate_hz, config) for p in model_pred01],
        MEAN_POSE: [np.tile(mean_pose, (len(s), 1)) for s in segments],
        SHIFTED: [shifted_truth(s.angles, shift) for s in segments],
    }
    result: dict[str, dict[str, dict[str, Any]]] = {}
    for subject in sorted({s.subject for s in segments}):
        idx = [i for i, s in enumerate(segments) if s.subject == subject]
        result[subject] = {
            system: subject_metrics(
                [segments[i] for i in idx], [preds[i] for i in idx], profile, rate_hz, config
            )
            for system, preds in systems.items()
        }
    return result


def average(results: dict[str, dict[str, dict[str, Any]]]) -> dict[str, dict[str, float]]:
    """Mean over subjects of every scalar measure, per system (Table 5.1's averaging)."""
    systems = next(iter(results.values())).keys() if results else []
    out: dict[str, dict[str, float]] = {}
    for system in systems:
        rows = [results[s][system] for s in results]
        keys = [k for k, v in rows[0].items() if isinstance(v, int | float)]
        out[system] = {k: float(np.nanmean([r[k] for r in rows])) for k in keys}
    return out


def table(
    results: dict[str, dict[str, dict[str, Any]]],
    title: str,
    columns: Sequence[Column] = TABLE_5_1,
) -> Table:
    """A rich table like Table 5.1: one row per subject and system, then the averages."""
    t = Table(title=title)
    t.add_column("Subject")
    t.add_column("System", no_wrap=True)
    for _, header, _, _ in columns:
        t.add_column(header, justify="right")

    def cells(row: dict[str, Any]) -> list[str]:
        return [fmt.format(row[k] * scale) if k in row else "–" for k, _, scale, fmt in columns]

    for subject, systems in results.items():
        for i, (system, row) in enumerate(systems.items()):
            t.add_row(subject if i == 0 else "", system, *cells(row))
        t.add_section()
    for i, (system, row) in enumerate(average(results).items()):
        t.add_row("[bold]average[/bold]" if i == 0 else "", system, *cells(row))
    return t
