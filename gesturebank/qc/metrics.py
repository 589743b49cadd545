"""QC metrics of one clip: pure functions over its arrays
(docs/architecture.md "The dataset on disk").

Radians and seconds inside; the reasons and plots convert to degrees. Every metric is
independent of the frame rate: shares of time, seconds, values on the analysis clock, or sizes
in shoulder widths — never counts of frames or pixels — so a 30 fps and a 60 fps copy of the same
motion are judged alike. Keypoints that were not seen (`Clip.valid`) take no part: an occluded
arm is masked in the angles, not held against the clip.

Jerkiness J (Eq. 3.21) is computed twice:

- `jerk_raw`: on the raw angles, i.e. straight from the 3D pose at the video's own timestamps.
  Video frame rates differ between takes (30, 50, 60 fps, and variable frame rate is real), and
  the J of frame-to-frame measurement noise grows as rate⁵ (Eq. 3.21 has f⁶ / f), so the same
  noise filmed at 60 fps would look 32× jerkier than at 30 fps. The raw angles are therefore first
  linearly resampled onto one uniform analysis clock (`analysis_rate_hz`, 30 Hz by default, the
  rate peers hard-code) using their real timestamps; gaps longer than `max_gap_s` stay NaN.
  This makes J comparable across takes, and is what the dataset-relative outlier check uses.
- `jerk`: on the processed angles (100 Hz, low-passed, clamped): what the model will learn.

Both are sums over the 11 joints (as Fig. 4.7); per-joint values are `jerk_raw/<Joint>` and
`jerk/<Joint>` (as Fig. 4.9).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from gesturebank.clip import PART_KEYPOINTS, PARTS, Clip, part_columns, part_mask, parts_of
from gesturebank.config import ProcessingConfig, QCConfig
from gesturebank.filters import resample_to_clock, unwrap_angles
from gesturebank.geometry import Camera
from gesturebank.lift.clip_confidence import expected_hand_error_cm
from gesturebank.qc.clip_metrics import ClipMetrics
from gesturebank.qc.invariants import invariant_metrics
from gesturebank.qc.table import CHECKS
from gesturebank.qc.views import (  # the framing functions, here since they were first written
    _share,
    _shoulder_width,
    facing_away,
    facing_away_from_all,
    sideways,
    sideways_from_all,
    take_cameras,
)
from gesturebank.robot.pepper import INDEX, JOINTS, RobotProfile
from gesturebank.robot.reach import out_of_reach, unlimited_angles
from gesturebank.skeletons import COCO17, to_coco17

if TYPE_CHECKING:
    pass

F64 = NDArray[np.float64]
# Gaps in the raw angles bridged before the jerk is measured: the processing's default, not the
# build's setting, so the same clip gets the same metric whatever config `qc` runs with.
_MAX_GAP_S = ProcessingConfig().max_gap_s

# Keypoints whose spikes and freezes the QC looks for (COCO-17 names): those the arm and hip
# angles are computed from, and the nose.
MOTION_KEYPOINTS = (
    "nose",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hip",
    "right_hip",
)
# Bones whose length must stay constant in a rigid 3D skeleton.
UPPER_BONES = (
    ("left_shoulder", "right_shoulder"),
    ("left_shoulder", "left_elbow"),
    ("left_elbow", "left_wrist"),
    ("right_shoulder", "right_elbow"),
    ("right_elbow", "right_wrist"),
    ("left_shoulder", "left_hip"),
    ("right_shoulder", "right_hip"),
    ("left_hip", "right_hip"),
)
_I = COCO17.index


# --------------------------------------------------------------------------------------------------
# Jerkiness


def jerkiness_per_joint(angles: np.ndarray, rate_hz: float) -> F64:
    """Angular jerkiness per joint `(D,)`, rad² s⁻⁵, of `angles (N, D)` sampled at `rate_hz`.

    Jerk, Eq. 3.21: J_j = 1 / (2 f (N − 3)) Σ_i (Δ³θ_ij f³)², with the third forward difference
    Δ³θ_i = θ_(i+3) − 3 θ_(i+2) + 3 θ_(i+1) − θ_i; i.e. ½ f⁵ mean_i (Δ³θ_i)². The sum over joints
    is the overall J of Eq. 3.21. Only differences over four finite samples count, and N − 3
    becomes their number; a joint without any is NaN.
    """
    a = np.asarray(angles, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    f = float(rate_hz)
    if not f > 0:
        raise ValueError(f"rate_hz must be positive, got {rate_hz!r}")
    if len(a) < 4:
        return np.full(a.shape[1], np.nan)
    d3 = a[3:] - 3 * a[2:-1] + 3 * a[1:-2] - a[:-3]  # Δ³θ, (N − 3, D)
    valid = np.isfinite(d3)
    n = valid.sum(axis=0)
    total = np.where(valid, d3, 0.0) ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, 0.5 * f**5 * total.sum(axis=0) / n, np.nan)


def uniform(values: np.ndarray, timestamps: np.ndarray, *, rate_hz: float, max_gap_s: float) -> F64:
    """`values (T, D)` at irregular `timestamps (T,)` linearly resampled to `rate_hz`: `(N, D)`.

    Gaps longer than `max_gap_s` stay NaN (see `filters.interpolate_at`).
    """
    v = np.asarray(values, dtype=np.float64)
    if len(v) < 2:
        return v.reshape(len(v), -1)
    _, out, _ = resample_to_clock(v, timestamps, rate_hz=rate_hz, max_gap_s=max_gap_s)
    return np.asarray(out, dtype=np.float64)


# --------------------------------------------------------------------------------------------------
# Detection coverage


def longest_run_s(bad: np.ndarray, timestamps: np.ndarray) -> float:
    """Longest run of True in `bad (T,)`, in seconds: from the run's first frame to the next
    frame after it (a run reaching the end lasts one more median frame interval)."""
    b = np.asarray(bad, dtype=bool)
    t = np.asarray(timestamps, dtype=np.float64)
    if not b.any():
        return 0.0
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    t_after = np.append(t[1:], t[-1] + dt)  # when each frame ends
    edges = np.diff(np.concatenate([[0], b.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return float(max(t_after[e - 1] - t[s] for s, e in zip(starts, stops, strict=True)))


# --------------------------------------------------------------------------------------------------
# Geometry of the 3D pose


def bone_cv(joints: np.ndarray, bones: Sequence[tuple[str, str]] = UPPER_BONES) -> F64:
    """Coefficient of variation (std / mean over frames) of each bone's length `(B,)` in
    `joints (T, 17, 3)` (COCO-17). A rigid skeleton gives 0; NaN frames are skipped."""
    j = np.asarray(joints, dtype=np.float64)
    out = np.full(len(bones), np.nan)
    for b, (p, q) in enumerate(bones):
        length = np.linalg.norm(j[:, _I[p]] - j[:, _I[q]], axis=-1)
        length = length[np.isfinite(length)]
        if len(length) >= 2 and length.mean() > 0:
            out[b] = length.std() / length.mean()
    return out


def _scale(points: np.ndarray) -> float:
    """Median shoulder width of `points (T, 17, D)`: the body's size in its own units."""
    w = np.linalg.norm(points[:, _I["left_shoulder"]] - points[:, _I["right_shoulder"]], axis=-1)
    w = w[np.isfinite(w)]
    return float(np.median(w)) if len(w) else float("nan")


def swap_events(points: np.ndarray, *, ratio: float = 0.5, min_move: float = 0.5) -> int:
    """Number of sudden left/right exchanges of the elbows and wrists in `points (T, 17, D)`.

    Between consecutive frames, `same` = Σ |L_t − L_(t−1)| + |R_t − R_(t−1)| over elbow and
    wrist, and `cross` the same with the previous frame's sides exchanged. A swap is a step where
    the arms moved more than `min_move` shoulder widths (`same`) but exchanging the sides explains
    the step (`cross < ratio · same`). Swapping back counts as another event.
    """
    return int(np.sum(swap_steps(points, ratio=ratio, min_move=min_move)))


def swap_steps(
    points: np.ndarray, *, ratio: float = 0.5, min_move: float = 0.5
) -> NDArray[np.bool_]:
    """`(T − 1,)` the steps between consecutive frames of `points (T, 17, D)` that are
    left/right exchanges of the arms (`swap_events` counts them)."""
    p = np.asarray(points, dtype=np.float64)
    if len(p) < 2:
        return np.zeros(max(len(p) - 1, 0), dtype=bool)
    left = p[:, [_I["left_elbow"], _I["left_wrist"]]]
    right = p[:, [_I["right_elbow"], _I["right_wrist"]]]

    def dist(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.linalg.norm(a - b, axis=-1).sum(axis=-1)

    same = dist(left[1:], left[:-1]) + dist(right[1:], right[:-1])
    cross = dist(left[1:], right[:-1]) + dist(right[1:], left[:-1])
    with np.errstate(invalid="ignore"):
        return np.asarray((same > min_move * _scale(p)) & (cross < ratio * same))


def frozen_fraction(points: np.ndarray, *, tol: float = 1e-6) -> float:
    """Share of consecutive-frame steps of `points (T, J, D)` where nothing moved at all
    (every finite coordinate changed by at most `tol` × the body's size): a held, not a tracked,
    pose. Only coordinates finite in both frames count; steps without any are skipped."""
    p = np.asarray(points, dtype=np.float64)
    if len(p) < 2:
        return 0.0
    flat = p.reshape(len(p), -1)
    both = np.isfinite(flat[1:]) & np.isfinite(flat[:-1])
    valid = both.any(axis=1)
    if not valid.any():
        return 0.0
    step = np.where(both, np.abs(np.diff(flat, axis=0)), 0.0).max(axis=1)
    size = float(np.nanstd(flat))
    return float(np.mean(step[valid] <= tol * max(size, 1e-12)))


def spike_sizes(points: np.ndarray, joints: Sequence[str] = MOTION_KEYPOINTS) -> F64:
    """How far each keypoint of `points (T, 17, D)` leaves the line between its neighbours in
    time, in shoulder widths: |p_t − (p_(t−1) + p_(t+1)) / 2| / width, `(T − 2, J)`; only where
    the excursion is larger than the step between the neighbours (it jumps out and back)."""
    p = np.asarray(points, dtype=np.float64)[:, [_I[j] for j in joints]]
    if len(p) < 3:
        return np.zeros((0, len(joints)))
    out = np.linalg.norm(p[1:-1] - (p[:-2] + p[2:]) / 2, axis=-1)
    through = np.linalg.norm(p[2:] - p[:-2], axis=-1)
    with np.errstate(invalid="ignore"):
        return np.where(out > through, out, 0.0) / _scale(points)


# --------------------------------------------------------------------------------------------------
# Angles


def _max(values: np.ndarray) -> float:
    finite = np.asarray(values)[np.isfinite(values)]
    return float(finite.max()) if finite.size else 0.0


def limit_frames(
    angles: np.ndarray, lower: np.ndarray, *, upper: np.ndarray, tol: float = 1e-5
) -> NDArray[np.bool_]:
    """`(N, D)` True where an angle of `angles (N, D)` sits on its limit (within `tol`)."""
    a = np.asarray(angles, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        return np.asarray((a <= np.asarray(lower) + tol) | (a >= np.asarray(upper) - tol))


def spectrum(values: np.ndarray, rate_hz: float) -> tuple[F64, F64]:
    """Power spectrum of each column of `values (N, D)`: `(freqs (F,), power (F, D))`.

    Each column's mean is removed; NaN samples are bridged linearly for the transform (a column
    without finite values is all zero). Periodogram with a Hann window.
    """
    v = np.array(values, dtype=np.float64, copy=True)
    if v.ndim == 1:
        v = v[:, None]
    idx = np.arange(len(v))
    for j in range(v.shape[1]):
        ok = np.isfinite(v[:, j])
        v[:, j] = np.interp(idx, idx[ok], v[ok, j]) - v[ok, j].mean() if ok.any() else 0.0
    window = np.hanning(len(v))[:, None]
    power = np.asarray(np.abs(np.fft.rfft(v * window, axis=0)) ** 2, dtype=np.float64)
    return np.asarray(np.fft.rfftfreq(len(v), 1.0 / rate_hz), dtype=np.float64), power


def high_freq_fraction(values: np.ndarray, *, rate_hz: float, above_hz: float = 7.0) -> float:
    """Share of the power of `values (N, D)` above `above_hz`, all columns together (the mean
    excluded): jitter. NaN when the clock cannot show `above_hz` or nothing moves."""
    if above_hz >= rate_hz / 2 or len(values) < 8:
        return float("nan")
    freqs, power = spectrum(values, rate_hz)
    total = power[1:].sum()
    return float(power[freqs > above_hz].sum() / total) if total > 0 else float("nan")


def motion_range(angles: np.ndarray) -> float:
    """Largest 5–95 % range of any joint of `angles (N, D)`, rad: ~0 for a static take."""
    a = np.asarray(angles, dtype=np.float64)
    ranges = [
        np.percentile(c[np.isfinite(c)], 95) - np.percentile(c[np.isfinite(c)], 5)
        for c in a.T
        if np.isfinite(c).sum() >= 2
    ]
    return float(max(ranges, default=0.0))


# --------------------------------------------------------------------------------------------------
# One clip


def measure_settings(qc: QCConfig) -> dict[str, float]:
    """The QC settings the metrics depend on (the rest are thresholds on them)."""
    return {
        "analysis_rate_hz": qc.analysis_rate_hz,
        "jitter_above_hz": qc.jitter_above_hz,
        "frozen_limit_tol": qc.frozen_limit_tol,
        "frozen_min_motion": qc.frozen_min_motion,
        "frozen_motion_window_s": qc.frozen_motion_window_s,
        "max_speed_factor": qc.max_speed_factor,
    }


def frozen_frames(
    held: np.ndarray, person: np.ndarray, *, rate_hz: float, min_motion: float, window_s: float
) -> NDArray[np.bool_]:
    """`(N, D)` the samples at which the robot's joint is held at a limit (`held (N, D)`) while
    the person's angle `person (N, D)` moves: it spans more than `min_motion` rad within the
    `window_s` around the sample, inside the same held run (issue 41: a limb folded past the
    limit and kept still is the robot's best pose, not a frozen one)."""
    out = np.zeros(held.shape, bool)
    half = max(1, round(window_s * rate_hz / 2))
    for j in range(held.shape[1]):
        edges = np.flatnonzero(np.diff(np.concatenate([[0], held[:, j].astype(np.int8), [0]])))
        for start, stop in zip(edges[::2], edges[1::2], strict=True):
            span = person[start:stop, j]
            if not np.isfinite(span).any():
                continue
            size = min(2 * half + 1, len(span))
            hi = maximum_filter1d(np.where(np.isfinite(span), span, -np.inf), size, mode="nearest")
            lo = minimum_filter1d(np.where(np.isfinite(span), span, np.inf), size, mode="nearest")
            with np.errstate(invalid="ignore"):
                out[start:stop, j] = np.isfinite(hi - lo) & (hi - lo > min_motion)
    return out


def frozen_spans_s(frozen: np.ndarray, *, rate_hz: float) -> F64:
    """Per column of `frozen (N, D)` (`frozen_frames`), its longest run in seconds: the robot
    stands frozen while the person moves. 0 where there is none."""
    out = np.zeros(frozen.shape[1])
    for j in range(frozen.shape[1]):
        edges = np.flatnonzero(np.diff(np.concatenate([[0], frozen[:, j].astype(np.int8), [0]])))
        if len(edges):
            out[j] = float(np.max(edges[1::2] - edges[::2])) / rate_hz
    return out


class ReachMetrics(NamedTuple):
    """The reach fields of `ClipMetrics` (`reach_metrics`)."""

    out_of_reach_fraction: float
    out_of_reach_per_joint: tuple[float, ...]
    frozen_at_limit_s_per_joint: tuple[float, ...]
    frozen_at_limit_s: float


def reach_frames(
    clip: Clip, *, profile: RobotProfile, qc: QCConfig, rate_hz: float
) -> tuple[NDArray[np.bool_], NDArray[np.bool_], F64]:
    """On the clip's 100 Hz clock `(N, 11)`: the person's angle beyond the robot's reach, the
    robot's joint held within qc.frozen_limit_tol of a limit (both where the joint is known),
    and the person's (unlimited, low-passed) angle."""
    n = len(clip.times)
    known = np.asarray(clip.mask, dtype=bool)
    if n < 2 or len(clip.raw_angles) < 2:
        person = np.full((n, len(JOINTS)), np.nan)
    else:
        processing = ProcessingConfig(rate_hz=rate_hz, cutoff_hz=min(4.0, rate_hz / 4))
        person, _ = unlimited_angles(
            raw=clip.raw_angles,
            timestamps=clip.timestamps,
            clock=clip.times,
            processing=processing,
            profile=profile,
        )
    beyond = out_of_reach(person, profile) & known
    a = np.asarray(clip.angles, dtype=np.float64)
    held = known & limit_frames(a, profile.lower, upper=profile.upper, tol=qc.frozen_limit_tol)
    return beyond, held, np.asarray(person, dtype=np.float64)


def reach_metrics(
    clip: Clip, *, profile: RobotProfile, qc: QCConfig, rate_hz: float
) -> ReachMetrics:
    """Motion beyond the robot's reach, reported: per joint (`out_of_reach/<Joint>`) the share
    of its known frames in which the person's low-passed angle lies beyond its limits, and
    `out_of_reach_fraction` (frames with any joint beyond); per joint the longest time frozen at
    a limit (`frozen_at_limit_s/<Joint>`) and its maximum `frozen_at_limit_s` (`frozen_spans_s`:
    the robot held within qc.frozen_limit_tol of a limit while the person's angle moves more
    than qc.frozen_min_motion)."""
    nan = float("nan")
    n = len(clip.times)
    beyond, held, person = reach_frames(clip, profile=profile, qc=qc, rate_hz=rate_hz)
    known = np.asarray(clip.mask, dtype=bool)
    moving = frozen_frames(held, person, rate_hz=rate_hz, min_motion=qc.frozen_min_motion,
                           window_s=qc.frozen_motion_window_s)  # fmt: skip
    frozen = frozen_spans_s(moving, rate_hz=rate_hz)
    return ReachMetrics(
        out_of_reach_fraction=float(beyond.any(axis=1).mean()) if n else nan,
        # 0 for a joint never seen (no NaN, so that two builds compare equal)
        out_of_reach_per_joint=tuple(
            float(np.sum(beyond[:, j]) / max(1, np.sum(known[:, j]))) for j in range(len(JOINTS))
        ),
        frozen_at_limit_s_per_joint=tuple(float(frozen[j]) for j in range(len(JOINTS))),
        frozen_at_limit_s=float(frozen.max()),
    )


def is_mocap(clip: Clip) -> bool:
    """Whether the clip's 3D is motion capture (measured, no camera): the view checks (facing
    away, sideways), set by what a view costs a lift, and the depth check do not apply."""
    return bool(clip.pose3d.meta.get("source") == "bvh")


def clip_hand_error_cm(clip: Clip) -> float:
    """The Pepper hand error (cm) the clip's depth confidence predicts for its lifter (the 3D
    pose's `lifter`); 0 for motion capture (measured 3D), NaN for a lifter not calibrated."""
    meta = clip.pose3d.meta
    if is_mocap(clip):
        return 0.0
    return expected_hand_error_cm(confidence=clip.depth_confidence, lifter=meta.get("lifter", ""))


def _part_unknown(known: np.ndarray, part: str) -> float:
    """Share of the 100 Hz clock in which no angle of `part` is known (NaN for no frames)."""
    return float(np.mean(~known[:, part_columns(part)].any(axis=1))) if len(known) else math.nan


def analysis_angles(clip: Clip, qc: QCConfig) -> F64:
    """The clip's raw angles `(N, 11)` on the uniform analysis clock (qc.analysis_rate_hz, from
    the first video frame), unwrapped; those of a part masked whole (issue 32) are glimpses the
    clip does not keep (a hand rising into a head-and-shoulders frame now and then): NaN."""
    raw = np.where(part_mask(parts_of(np.asarray(clip.mask, bool))), clip.raw_angles, np.nan)
    if len(raw) < 2:
        return np.empty((0, len(JOINTS)))
    # unwrapped first: a step across ±π (an angle beyond the robot's range) is no motion
    return uniform(
        unwrap_angles(raw), clip.timestamps, rate_hz=qc.analysis_rate_hz, max_gap_s=_MAX_GAP_S
    )


class JudgedPoints(NamedTuple):
    """The keypoints a clip is judged by (`judged_points`), per video frame."""

    valid: NDArray[np.bool_]  # (T, 17) seen, and of a body part the clip keeps
    xy: F64  # (T, 17, 2) the stored 2D, COCO-17 pixels
    seen_xy: F64  # (T, 17, 2) the same, NaN where not valid
    joints: F64  # (T, 17, 3) the 3D, NaN where not valid
    cameras: list[Camera]  # a multi-camera take's cameras ([] for one camera)
    shoulders: NDArray[np.bool_]  # (T,) both shoulders seen

    @property
    def shapes(self) -> list[F64]:
        """What spikes, swaps and freezes are looked for in: one camera's 2D and its 3D, or the
        triangulated 3D alone (one camera's 2D glitch is outvoted by the others)."""
        return [self.joints] if self.cameras else [self.seen_xy, self.joints]


def judged_points(clip: Clip) -> JudgedPoints:
    """The clip's keypoints as the QC judges them: those of a part masked whole (issue 32) are
    left out, as if unseen (the clip does not keep them)."""
    known = np.asarray(clip.mask, dtype=bool)
    valid = np.asarray(clip.valid, dtype=bool).copy()
    for part in set(PARTS) - parts_of(known):
        valid[:, [_I[k] for k in PART_KEYPOINTS[part]]] = False
    xy = to_coco17(clip.pose2d.keypoints, clip.pose2d.skeleton)[..., :2].astype(np.float64)
    seen_xy = np.where(valid[..., None], xy, np.nan)
    joints = np.where(valid[..., None], np.asarray(clip.pose3d.joints, np.float64), np.nan)
    shoulders = valid[:, _I["left_shoulder"]] & valid[:, _I["right_shoulder"]]
    return JudgedPoints(valid, xy, seen_xy, joints, take_cameras(clip.pose3d), shoulders)


def view_flags(points: JudgedPoints) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """`(T,)` frames facing away and seen from the side: by the clip's own 2D, or for a
    multi-camera take by its 3D as every camera sees it (`facing_away_from_all`)."""
    if points.cameras:
        views = [c.project(points.joints) for c in points.cameras]
        return facing_away_from_all(views, points.valid), sideways_from_all(views, points.valid)
    return facing_away(points.xy, points.valid), sideways(points.xy, points.valid)


def clip_metrics(clip: Clip, *, profile: RobotProfile, qc: QCConfig) -> ClipMetrics:
    """All QC metrics of one clip, as plain floats (NaN where a metric has nothing to measure;
    `ClipMetrics` says what each is). trimmed_fraction, of the whole take, is left to the build.

    Keypoints and raw angles of a body part the clip does not have (masked whole,
    `clip.parts_of`) are left out, as if unseen. A multi-camera take (its 3D pose's `cameras`,
    `take_cameras`) is judged by its 3D:
    spikes, swaps and freezes of the triangulated joints only, facing away and sideways as every
    camera sees them (`facing_away_from_all`), the person's size in the camera that sees them
    largest. The stored 2D (the reference camera's) is then only drawn, not judged.
    """
    nan = float("nan")
    rate = 1.0 / float(np.median(np.diff(clip.times))) if len(clip.times) > 1 else 100.0
    hz = qc.analysis_rate_hz
    known = np.asarray(clip.mask, dtype=bool)
    raw_u = analysis_angles(clip, qc)
    j_raw = jerkiness_per_joint(raw_u, hz) if len(raw_u) else np.full(len(JOINTS), nan)
    j_proc = jerkiness_per_joint(clip.angles, rate)
    jerk_raw = float(np.nansum(j_raw)) if np.isfinite(j_raw).any() else nan
    jerk = float(np.nansum(j_proc)) if np.isfinite(j_proc).any() else nan

    head = known[:, [INDEX["HeadPitch"], INDEX["HeadYaw"]]].any(axis=1)
    arms = known[:, [INDEX["LShoulderPitch"], INDEX["RShoulderPitch"]]].any(axis=1)

    pts = judged_points(clip)
    valid, xy, joints, shoulders = pts.valid, pts.xy, pts.joints, pts.shoulders
    cv = bone_cv(joints)
    shapes = pts.shapes
    upper = [_I[j] for j in MOTION_KEYPOINTS]
    away, side = view_flags(pts)
    if pts.cameras:  # the person's size in the best camera
        views = [c.project(joints) for c in pts.cameras]
        both = [_I["left_shoulder"], _I["right_shoulder"]]  # a camera they lie behind: unseen
        sizes = [
            _shoulder_width(v, shoulders & np.isfinite(v[:, both, 0]).all(axis=1), c.size[1])
            for v, c in zip(views, pts.cameras, strict=True)
        ]
        width_share = max(sizes, key=lambda w: w if np.isfinite(w) else -np.inf)
    else:
        width_share = _shoulder_width(xy, shoulders, clip.pose2d.image_size[1])
    change = np.asarray(clip.change, dtype=np.float64)
    reach = reach_metrics(clip, profile=profile, qc=qc, rate_hz=rate)
    return ClipMetrics(
        duration_s=clip.duration_s,
        jerk_raw=jerk_raw,
        jerk=jerk,
        jerk_raw_per_joint=tuple(float(j) for j in j_raw),
        jerk_per_joint=tuple(float(j) for j in j_proc),
        head_unknown_fraction=float(np.mean(~head)) if len(known) else nan,
        arms_unknown_fraction=float(np.mean(~arms)) if len(known) else nan,
        left_arm_unknown_fraction=_part_unknown(known, "left_arm"),
        right_arm_unknown_fraction=_part_unknown(known, "right_arm"),
        torso_gap_s=longest_run_s(~shoulders, clip.timestamps),
        bone_cv_max=float(np.nanmax(cv)) if np.isfinite(cv).any() else nan,
        swap_events=float(max(swap_events(p) for p in shapes)),
        frozen_fraction=max(frozen_fraction(p[:, upper]) for p in shapes),
        spike_max=float(max(_max(spike_sizes(p)) for p in shapes)),
        out_of_reach_fraction=reach.out_of_reach_fraction,
        out_of_reach_per_joint=reach.out_of_reach_per_joint,
        frozen_at_limit_s_per_joint=reach.frozen_at_limit_s_per_joint,
        frozen_at_limit_s=reach.frozen_at_limit_s,
        invariants=invariant_metrics(clip, profile=profile, qc=qc, jerk=jerk, jerk_raw=jerk_raw),
        jitter_fraction=high_freq_fraction(raw_u, rate_hz=hz, above_hz=qc.jitter_above_hz)
        if len(raw_u)
        else nan,
        motion_range=motion_range(clip.angles),
        # motion capture has no camera: a view cannot cost its measured 3D anything (issue 41)
        facing_away_fraction=nan if is_mocap(clip) else _share(away, shoulders),
        sideways_fraction=nan if is_mocap(clip) else _share(side, shoulders & valid[:, _I["nose"]]),
        shoulder_width=width_share,
        image_change=(
            float(np.median(change[np.isfinite(change)])) if np.isfinite(change).any() else nan
        ),
        people=float(np.mean(clip.n_people)) if len(clip.n_people) else nan,
        speech_fraction=float(np.mean(clip.speech)) if len(clip.speech) else nan,
        depth_confidence=(
            float(np.mean(clip.depth_confidence)) if len(clip.depth_confidence) else nan
        ),
        expected_hand_error_cm=clip_hand_error_cm(clip),
        extra={c.metric: float(c.measure(clip, qc, profile)) for c in CHECKS if c.measure},
    )
