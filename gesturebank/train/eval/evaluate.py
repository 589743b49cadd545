"""Evaluation of predicted motion per subject, with baselines, as in Table 5.1 of the dissertation.

For every test segment the model's normalised output is turned into angles as in synthesis
(ν⁻¹, then the Butterworth post-smoothing of §4.4.1, then clamping to the limits) and compared
with the ground truth. Four baselines are scored the same way in every evaluation:
- "mean pose": the static mean of the training targets (no motion at all);
- "shifted truth": the ground truth itself, `shift_baseline_s` late (real motion, wrong timing);
  it is undefined for the first frames and after unknown ones, which its scores leave out;
- "natural motion": the held-out ground truth itself (the ceiling: errors 0, FGD 0; its jerk,
  acceleration and beat consistency are what natural motion scores);
- "shuffled clip": the natural motion of another clip, chosen at random (`eval.shuffle_seed`),
  cut to length (unknown where the donor is shorter): real motion unrelated to the speech.

The field's measures (GENEA 2022, BEAT) sit beside the seeds': GENEA's average acceleration and
jerk (rad/s², rad/s³), Hellinger distances of the speed and acceleration histograms, FGD (when a
feature autoencoder is given, `train.fgd`) and beat consistency (when audio onsets are given,
`train.beats`); without those inputs the two keys are absent, not None.

Per subject: L, RMSE and APE pool all frames where truth and prediction are known; the sequence
measures run over the contiguous stretches where both whole poses are known: CCA, FCCA and local
CCA over those at least as long as the LCCA window (a shorter one has too few frames for its
dimensions and would score 1.0), jerkiness and speed histograms over those of ≥ 4 frames. Local
CCA pools the windows of all stretches (Eq. 3.18), J̃ and ΔJ̃ average over stretches (Eq. 3.22).
A measure without the data it needs is None and the row says why (`not_computable`), rather than
a number. The table's average row is the mean over the subjects where a measure is computable.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from gesturebank.config import AudioConfig, TrainConfig
from gesturebank.datasets.torch import Segment
from gesturebank.filters import butter_lowpass
from gesturebank.robot import pepper
from gesturebank.train.eval import beats as B
from gesturebank.train.eval import metrics as M
from gesturebank.train.eval.fgd import FeatureModel, chunks

MIN_RUN = 4  # frames: the shortest stretch jerkiness is defined on
MEAN_POSE = "mean pose"
SHIFTED = "shifted truth"
NATURAL = "natural motion"
SHUFFLED = "shuffled clip"

LOWER, HIGHER, NEAR_NATURAL = "↓", "↑", "≈"
LEGEND = (
    f"{LOWER} lower is better · {HIGHER} higher is better · "
    f"{NEAR_NATURAL} closer to natural motion's value is better"
)


class Column(NamedTuple):
    key: str
    header: str
    scale: float
    fmt: str
    better: str  # LOWER, HIGHER or NEAR_NATURAL

    @property
    def title(self) -> str:
        """The header with its better-direction mark, e.g. 'RMSE (°) ↓'."""
        return f"{self.header} {self.better}"

    @property
    def short(self) -> str:
        """The header without its unit, e.g. 'RMSE ↓' (narrow tables; the unit in `units`)."""
        return f"{self.header.split(' (')[0]} {self.better}"

    @property
    def unit(self) -> str:
        """The unit in the header's parentheses ('' when none)."""
        _, sep, rest = self.header.partition(" (")
        return rest.removesuffix(")") if sep else ""


# The columns of Table 5.1, a second table with the other seeds' measures and a third with the
# field's; a measure is shown in one of them only.
TABLE_5_1: tuple[Column, ...] = (
    Column("loss_l", "Loss L", 1.0, "{:.4f}", LOWER),
    Column("rmse_deg", "RMSE (°)", 1.0, "{:.2f}", LOWER),
    Column("delta_lcca", "ΔLCCA", 1.0, "{:.3f}", LOWER),  # Eq. 3.20: a distance
    Column("lcca_theta", "LCCA_Θ", 1.0, "{:.4f}", HIGHER),
    Column("delta_jerk", "ΔJ̃ (10⁵ rad²s⁻⁵)", 1e-5, "{:.3f}", LOWER),
)
SEED_MEASURES: tuple[Column, ...] = (
    Column("cca", "CCA", 1.0, "{:.3f}", HIGHER),
    Column("fcca", "FCCA", 1.0, "{:.3f}", HIGHER),
    Column("ape_deg", "APE (°)", 1.0, "{:.2f}", LOWER),
)
# GENEA 2022 and BEAT: the numbers the field compares. Acceleration, jerk and beat consistency
# are best near natural motion's (jittery motion scores high on all three; BEAT's "higher is
# better" holds only for motion as smooth as the real one).
FIELD_MEASURES: tuple[Column, ...] = (
    Column("avg_accel", "Acc (rad/s²)", 1.0, "{:.2f}", NEAR_NATURAL),
    Column("avg_jerk", "Jerk (rad/s³)", 1.0, "{:.1f}", NEAR_NATURAL),
    Column("hellinger_speed", "H speed", 1.0, "{:.3f}", LOWER),  # seed 001's = GENEA's
    Column("hellinger_accel", "H acc", 1.0, "{:.3f}", LOWER),
    Column("fgd", "FGD", 1.0, "{:.3f}", LOWER),
    Column("beat_consistency", "BC", 1.0, "{:.3f}", NEAR_NATURAL),
)


def postprocess(
    pred01: np.ndarray, profile: pepper.RobotProfile, *, rate_hz: float, config: TrainConfig
) -> np.ndarray:
    """Model output `(N, 11)` in [0, 1] → angles `(N, 11)` rad: ν⁻¹, low-pass (§4.4.1), clamp."""
    angles = pepper.denormalise(pred01, profile)  # ν⁻¹ of Eq. 3.14
    smooth = butter_lowpass(
        angles, rate_hz, cutoff_hz=config.smoothing_cutoff_hz, order=config.smoothing_order
    )
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


# Measures by what they need; one that cannot be computed is None, with the reason in
# "not_computable" (a CCA of fewer frames than dimensions is 1.0 whatever the data).
ERROR_KEYS = ("loss_l", "rmse_rad", "rmse_deg", "ape_rad", "ape_deg")
CCA_KEYS = ("lcca_theta", "lcca_audio_true", "lcca_audio_pred", "delta_lcca", "cca", "fcca")
MOTION_KEYS = (
    "jerk_pred",
    "jerk_true",
    "delta_jerk",
    "hellinger_speed",
    "avg_accel",
    "avg_jerk",
    "hellinger_accel",
)
# The groups of "not_computable" and the measures each leaves as None.
EVERY = "every measure"
CCA_GROUP, MOTION_GROUP, FGD_GROUP, BEAT_GROUP = (
    "LCCA, CCA, FCCA",
    "jerk, speeds",
    "FGD",
    "beat consistency",
)
GROUP_KEYS: dict[str, tuple[str, ...]] = {
    CCA_GROUP: CCA_KEYS,
    MOTION_GROUP: MOTION_KEYS,
    FGD_GROUP: ("fgd",),
    BEAT_GROUP: ("beat_consistency",),
}


def shuffled_clip(
    segments: Sequence[Segment], donors: Sequence[Segment], *, seed: int
) -> list[np.ndarray]:
    """For each segment the angles `(n, 11)` of a random donor from another clip (another piece
    of the same clip when no other clip is there; NaN when neither is), cut to the segment's
    length and NaN past the donor's end."""
    rng = np.random.default_rng(seed)
    out = []
    for s in segments:
        others = [d for d in donors if d.clip_id != s.clip_id] or [
            d for d in donors if d.clip_id == s.clip_id and d.start != s.start
        ]
        motion = np.full((len(s), s.angles.shape[1]), np.nan, dtype=np.float32)
        if others:
            donor = others[int(rng.integers(len(others)))].angles[: len(s)]
            motion[: len(donor)] = donor
        out.append(motion)
    return out


def subject_metrics(
    segments: Sequence[Segment],
    predictions: Sequence[np.ndarray],
    *,
    profile: pepper.RobotProfile,
    rate_hz: float,
    config: TrainConfig,
    fgd: FeatureModel | None = None,
    onsets: Sequence[np.ndarray] | None = None,
) -> dict[str, Any]:
    """Every measure for one subject: segments' ground truth vs `predictions` `(n_k, 11)` rad.

    A measure without enough data is None and `not_computable` maps its group to the reason:
    the errors need a frame where both are known, the CCA measures a stretch of known poses at
    least as long as the LCCA window, jerkiness and speeds a stretch of `MIN_RUN` frames, FGD
    two chunks of `eval.fgd_chunk_s`, beat consistency an audio onset inside a stretch.
    `onsets` are each segment's audio onset frames (`segment_onsets`).
    """
    field_keys = (*(("fgd",) if fgd else ()), *(("beat_consistency",) if onsets else ()))
    pred = np.concatenate(predictions).astype(np.float64)
    true = np.concatenate([s.angles for s in segments]).astype(np.float64)
    true[~np.isfinite(pred)] = np.nan  # score only frames where both are known
    known = np.isfinite(true)
    out: dict[str, Any] = {"frames": int(known.any(axis=1).sum()), "not_computable": {}}
    out |= dict.fromkeys((*ERROR_KEYS, *CCA_KEYS, *MOTION_KEYS, *field_keys))
    out["rmse_per_joint_rad"] = out["rmse_per_joint_deg"] = dict.fromkeys(pepper.JOINTS)
    if out["frames"] == 0:
        out["not_computable"][EVERY] = "no frame where the truth and this system are both known"
        return out
    true01 = np.where(known, pepper.normalise(np.nan_to_num(true), profile), np.nan)
    pred01 = pepper.normalise(pred, profile)
    per_joint = M.rmse_per_joint(true, pred)
    out |= {
        "loss_l": M.loss_l(true01, pred01),  # Eq. 3.15
        "rmse_rad": M.rmse(true, pred),  # Eq. 3.12
        "ape_rad": M.ape(true[known], pred[known]),
    }
    out["rmse_deg"] = float(np.degrees(out["rmse_rad"]))
    out["ape_deg"] = float(np.degrees(out["ape_rad"]))
    out["rmse_per_joint_rad"] = _joints(per_joint)
    out["rmse_per_joint_deg"] = _joints(np.degrees(per_joint))

    window = max(2, round(config.lcca_window_s * rate_hz))
    t_runs, p_runs, a_runs, o_runs = [], [], [], []
    for k, (s, p) in enumerate(zip(segments, predictions, strict=True)):
        both = np.isfinite(s.angles).all(axis=1) & np.isfinite(p).all(axis=1)
        for a, b in _runs(both):
            t_runs.append(s.angles[a:b].astype(np.float64))
            p_runs.append(np.asarray(p[a:b], dtype=np.float64))
            a_runs.append(s.audio[a:b].astype(np.float64))
            if onsets:
                o_runs.append(onsets[k][(onsets[k] >= a) & (onsets[k] < b)] - a)
    long_ = [i for i, t in enumerate(t_runs) if len(t) >= window]
    if long_:
        out |= _cca_measures(
            truth=[t_runs[i] for i in long_],
            pred=[p_runs[i] for i in long_],
            audio=[a_runs[i] for i in long_],
            window=window,
            stride=config.lcca_stride,
        )
    else:
        longest = max((len(t) for t in t_runs), default=0) / rate_hz
        out["not_computable"][CCA_GROUP] = (
            f"no stretch of whole known poses as long as the {config.lcca_window_s:g} s LCCA "
            f"window (longest {longest:.2f} s)"
        )
    if t_runs:
        j_mean, dj_mean = M.mean_jerkiness(t_runs, p_runs, rate_hz=rate_hz)  # Eq. 3.22
        h_true, h_pred = (
            M.speed_histogram(
                np.concatenate([M.speeds(x, rate_hz) for x in runs]),
                config.speed_bin,
                top=config.speed_max,
            )
            for runs in (t_runs, p_runs)
        )
        out |= {
            "jerk_pred": j_mean,
            "jerk_true": float(np.mean([M.jerkiness(t, rate_hz) for t in t_runs])),
            "delta_jerk": dj_mean,
            "hellinger_speed": M.hellinger(h_true, h_pred),  # seed 001, Eq. 2
        }
        out |= _genea_measures(t_runs, p_runs, rate_hz, config)
    else:
        out["not_computable"][MOTION_GROUP] = f"no stretch of {MIN_RUN} whole known poses"
    if fgd is not None:
        out |= _fgd_measure(out["not_computable"], t_runs, p_runs, fgd, rate_hz, config)
    if onsets:
        scores = [
            B.beat_scores(
                audio_beats_s=o / rate_hz,
                motion_beats_s=B.motion_beats(
                    p, rate_hz=rate_hz, order_s=config.eval.beat_min_order_s
                )
                / rate_hz,
                sigma_s=config.eval.beat_sigma_s,
            )
            for o, p in zip(o_runs, p_runs, strict=True)
        ]
        pooled = np.concatenate(scores) if scores else np.zeros(0)
        if pooled.size:
            out["beat_consistency"] = float(np.mean(pooled))  # BEAT, over every audio beat
        else:
            out["not_computable"][BEAT_GROUP] = "no audio onset inside a known stretch"
    return out


def _genea_measures(
    t_runs: list[np.ndarray], p_runs: list[np.ndarray], rate_hz: float, config: TrainConfig
) -> dict[str, float]:
    """GENEA 2022's average acceleration and jerk of the prediction, and the Hellinger distance
    of the acceleration histograms, over stretches of ≥ `MIN_RUN` frames."""

    def norms(runs: list[np.ndarray], order: int) -> np.ndarray:
        return np.concatenate([M.derivative_norms(x, rate_hz=rate_hz, order=order) for x in runs])

    e = config.eval
    h_true, h_pred = (
        M.speed_histogram(norms(runs, 2), e.accel_bin, top=e.accel_max) for runs in (t_runs, p_runs)
    )
    return {
        "avg_accel": float(np.mean(norms(p_runs, 2))),
        "avg_jerk": float(np.mean(norms(p_runs, 3))),
        "hellinger_accel": M.hellinger(h_true, h_pred),
    }


def _fgd_measure(
    reasons: dict[str, str],
    t_runs: list[np.ndarray],
    p_runs: list[np.ndarray],
    fgd: FeatureModel,
    rate_hz: float,
    config: TrainConfig,
) -> dict[str, float]:
    """FGD of the prediction's chunks against the truth's, or a reason in `reasons`."""
    real = chunks(t_runs, rate_hz=rate_hz, config=config.eval)
    gen = chunks(p_runs, rate_hz=rate_hz, config=config.eval)
    if min(len(real), len(gen)) < 2:
        reasons[FGD_GROUP] = (
            f"fewer than 2 chunks of {config.eval.fgd_chunk_s:g} s of whole known poses"
        )
        return {}
    return {"fgd": fgd.fgd(real=real, generated=gen)}


def segment_onsets(
    features: Sequence[np.ndarray], *, audio: AudioConfig, rate_hz: float, config: TrainConfig
) -> list[np.ndarray]:
    """Audio onset frames of each segment from its un-normalised features `(n, F)`."""
    e = config.eval
    return [
        B.onsets(
            B.energy_bands(f, audio=audio),
            rate_hz=rate_hz,
            delta=e.onset_delta,
            wait_s=e.onset_wait_s,
            window_s=e.onset_window_s,
        )
        for f in features
    ]


def _cca_measures(
    *,
    truth: list[np.ndarray],
    pred: list[np.ndarray],
    audio: list[np.ndarray],
    window: int,
    stride: int,
) -> dict[str, float]:
    """The CCA family over stretches `(n_i, ·)` at least `window` frames long."""

    def pooled(xs: list[np.ndarray], ys: list[np.ndarray]) -> float:
        values = [
            M.local_cca_values(x, y, window=window, stride=stride)
            for x, y in zip(xs, ys, strict=True)
        ]
        return float(np.mean(np.concatenate(values)))  # Eq. 3.18, windows of all stretches

    lcca_at = pooled(audio, truth)
    lcca_ap = pooled(audio, pred)
    return {
        "lcca_theta": pooled(truth, pred),  # Eq. 3.19
        "lcca_audio_true": lcca_at,
        "lcca_audio_pred": lcca_ap,
        "delta_lcca": abs(lcca_at - lcca_ap),  # Eq. 3.20
        "cca": float(np.mean([M.cca(t, p) for t, p in zip(truth, pred, strict=True)])),
        "fcca": float(
            np.mean([M.fcca(t, p, audio=a) for t, p, a in zip(truth, pred, audio, strict=True)])
        ),
    }


def _joints(values: np.ndarray) -> dict[str, float | None]:
    """Per-joint values by name; None for a joint never known."""
    return {
        j: float(v) if np.isfinite(v) else None for j, v in zip(pepper.JOINTS, values, strict=True)
    }


def evaluate_segments(
    segments: Sequence[Segment],
    model_pred01: Sequence[np.ndarray],
    *,
    name: str,
    mean_pose01: np.ndarray,
    profile: pepper.RobotProfile,
    rate_hz: float,
    config: TrainConfig,
    donors: Sequence[Segment] = (),
    fgd: FeatureModel | None = None,
    onsets: Sequence[np.ndarray] | None = None,
) -> dict[str, dict[str, dict[str, Any]]]:
    """{subject → {system → metrics}} for the model (post-processed) and the baselines.

    The shuffled clip's donors are `segments` and `donors` (e.g. the train part's).
    """
    systems = {
        name: [postprocess(p, profile, rate_hz=rate_hz, config=config) for p in model_pred01]
    }
    systems |= baselines(
        segments,
        mean_pose01=mean_pose01,
        profile=profile,
        rate_hz=rate_hz,
        config=config,
        donors=donors,
    )
    return score_systems(
        segments, systems, profile=profile, rate_hz=rate_hz, config=config, fgd=fgd, onsets=onsets
    )


def baselines(
    segments: Sequence[Segment],
    *,
    mean_pose01: np.ndarray,
    profile: pepper.RobotProfile,
    rate_hz: float,
    config: TrainConfig,
    donors: Sequence[Segment] = (),
) -> dict[str, list[np.ndarray]]:
    """The baselines' motion per segment: natural, mean pose, shuffled clip, shifted truth."""
    mean_pose = pepper.denormalise(np.asarray(mean_pose01)[None], profile)[0]
    shift = round(config.shift_baseline_s * rate_hz)
    return {
        NATURAL: [s.angles for s in segments],
        MEAN_POSE: [np.tile(mean_pose, (len(s), 1)) for s in segments],
        SHUFFLED: shuffled_clip(segments, [*segments, *donors], seed=config.eval.shuffle_seed),
        SHIFTED: [shifted_truth(s.angles, shift) for s in segments],
    }


def score_systems(
    segments: Sequence[Segment],
    systems: dict[str, list[np.ndarray]],
    *,
    profile: pepper.RobotProfile,
    rate_hz: float,
    config: TrainConfig,
    fgd: FeatureModel | None = None,
    onsets: Sequence[np.ndarray] | None = None,
) -> dict[str, dict[str, dict[str, Any]]]:
    """{subject → {system → metrics}} of each system's angles `(n_k, 11)` per segment."""
    result: dict[str, dict[str, dict[str, Any]]] = {}
    for subject in sorted({s.subject for s in segments}):
        idx = [i for i, s in enumerate(segments) if s.subject == subject]
        result[subject] = {
            system: subject_metrics(
                [segments[i] for i in idx],
                [preds[i] for i in idx],
                profile=profile,
                rate_hz=rate_hz,
                config=config,
                fgd=fgd,
                onsets=[onsets[i] for i in idx] if onsets else None,
            )
            for system, preds in systems.items()
        }
    return result


def average(
    results: dict[str, dict[str, dict[str, Any]]],
) -> dict[str, dict[str, float | None]]:
    """Mean over subjects of every scalar measure, per system (Table 5.1's averaging)."""
    systems = next(iter(results.values())).keys() if results else []
    out: dict[str, dict[str, float | None]] = {}
    for system in systems:
        rows = [results[s][system] for s in results]
        keys = [k for k, v in rows[0].items() if v is None or isinstance(v, int | float)]
        known = {k: [r[k] for r in rows if r[k] is not None] for k in keys}
        # the mean over the subjects where a measure is computable; None where it is for none
        out[system] = {k: float(np.mean(v)) if v else None for k, v in known.items()}
    return out
