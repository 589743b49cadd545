"""Gross outliers of a triangulated take: left/right swaps per camera, and joints whose bone
lengths or motion disagree with the rest of the take.

Reprojection error alone cannot see every wrong joint: when two cameras agree on a mislabelled
elbow (a left/right swap in one view, whose epipolar line runs through both elbows), the point
reprojects well but lies far from the arm. So, around the DLT with camera exclusion:

0. Back views: a camera that sees the person's back (the torso's forward direction, from a
   first triangulation of the torso, points away from it) gives no nose or eyes — the detector
   guesses them there — wherever enough cameras facing the person saw them (`unseen_face`).
1. Swaps (Pose2Sim's retry): where a left/right pair reprojects badly, each camera's labels of
   the pair are exchanged in turn; the exchange that halves the pair's all-camera error is kept
   (where several cameras' exchanges would, as always with two, the camera whose labels jumped).
   For the shoulders and hips also where their distance is off the take's median and the
   exchange brings it back (two cameras can agree on a swap: it reprojects well).
2. Consistency, joint by joint from the torso outwards (`PARENT`): a joint is suspect where its
   bone to its parent is off the take's median length by more than `max_bone_dev`, or where it
   leaves the running median of its own track by more than `max_jump` shoulder widths.
3. Each suspect point is solved again RANSAC-style: every camera pair, each camera with its own
   or the mirrored label, seeds a point; the cameras that agree with it (either label) join;
   the candidate that best fits its bone, its track and the images wins. A point that still
   disagrees becomes NaN (a short gap that the 3D repair fills).
"""

from __future__ import annotations

import itertools
import logging
import warnings
from dataclasses import dataclass

import numpy as np

from gesturebank.camera_files import CameraGroup
from gesturebank.geometry import frame_from, torso_vectors
from gesturebank.lift.multiview.triangulate import dlt, reprojection_errors
from gesturebank.skeletons import COCO17

log = logging.getLogger(__name__)

_I = COCO17.index
# The joints a joint's bones lead to, solved in this order (the torso first, then outwards):
# a torso joint is checked against the other three, a limb or face joint against its parent.
_TORSO = ("left_shoulder", "right_shoulder", "left_hip", "right_hip")
PARENTS: dict[str, tuple[str, ...]] = {
    **{j: tuple(k for k in _TORSO if k != j) for j in _TORSO},
    "nose": (),
    "left_eye": ("nose",),
    "right_eye": ("nose",),
    "left_ear": ("left_eye",),
    "right_ear": ("right_eye",),
    "left_elbow": ("left_shoulder",),
    "right_elbow": ("right_shoulder",),
    "left_wrist": ("left_elbow",),
    "right_wrist": ("right_elbow",),
    "left_knee": ("left_hip",),
    "right_knee": ("right_hip",),
    "left_ankle": ("left_knee",),
    "right_ankle": ("right_knee",),
}
_TRACK_WINDOW = 7  # frames of the running median a joint's track is compared with
# Left/right pairs a constant distance apart (bones across the body), named by their left side.
RIGID = ("left_shoulder", "left_hip")


def mirror(joint: str) -> str | None:
    """'left_elbow' → 'right_elbow' and back; None for the nose."""
    for a, b in (("left_", "right_"), ("right_", "left_")):
        if joint.startswith(a):
            return b + joint[len(a) :]
    return None


# (J,) index of each joint's mirror image (itself for the nose)
MIRROR = np.array([_I[m] if (m := mirror(n)) else j for j, n in enumerate(COCO17.joints)])


@dataclass(frozen=True, eq=False)
class Views:
    """The observations of a take in normalised image coordinates.

    normalised: (C, T, J, 2) undistorted normalised coordinates; NaN = not seen.
    weights:    (C, T, J) DLT weight (the confidence; 0 = ignored).
    extrinsics: (C, 3, 4) world → camera; focals (C, 2) px per normalised unit.
    """

    normalised: np.ndarray
    weights: np.ndarray
    extrinsics: np.ndarray
    focals: np.ndarray

    @classmethod
    def of(cls, keypoints: np.ndarray, cameras: CameraGroup, *, min_confidence: float) -> Views:
        """From raw keypoints (C, T, J, 3) = x px, y px, confidence; below `min_confidence`
        (or NaN) an observation gets weight 0."""
        kp = np.asarray(keypoints, np.float64)
        normalised = cameras.undistort_points(kp[..., :2], normalised=True)
        conf = np.nan_to_num(kp[..., 2])
        ok = np.isfinite(normalised).all(-1) & (conf >= min_confidence)
        return cls(
            normalised,
            np.where(ok, conf, 0.0),
            np.stack([c.extrinsics for c in cameras]),
            np.stack([np.diag(c.K)[:2] for c in cameras]),
        )

    def relabel(self, mirrored: np.ndarray) -> Views:
        """These views with camera c's joint j taken from its mirror joint where `mirrored`."""
        return Views(
            relabel(self.normalised, mirrored),
            relabel(self.weights, mirrored),
            self.extrinsics,
            self.focals,
        )


@dataclass(frozen=True)
class Cleaning:
    """What `fix_swaps` and `make_consistent` changed: counts of (camera, frame, pair) label
    exchanges, suspect points, points solved again, points rejected (NaN)."""

    swapped: int = 0
    suspects: int = 0
    resolved: int = 0
    rejected: int = 0


def _pair_fit(views: Views, jl: int, jr: int) -> tuple[np.ndarray, np.ndarray]:
    """(T,) all-camera mean reprojection error of joints jl and jr, summed (inf if unsolved),
    and (T,) the distance between their two points (NaN if unsolved)."""
    total = np.zeros(views.normalised.shape[1])
    points = []
    for j in (jl, jr):
        obs, w = views.normalised[:, :, j], views.weights[:, :, j]
        p = dlt(obs, views.extrinsics, weights=w)
        err = reprojection_errors(p, obs, extrinsics=views.extrinsics, focals=views.focals)
        used = w > 0
        mean = np.where(used, np.nan_to_num(err, nan=0.0), 0.0).sum(0) / np.maximum(used.sum(0), 1)
        total += np.where(np.isfinite(p).all(-1) & (used.sum(0) >= 2), mean, np.inf)
        points.append(p)
    return total, np.linalg.norm(points[0] - points[1], axis=-1)


def _width_dev(width: np.ndarray, median: float) -> np.ndarray:
    """(T,) relative deviation of a left-right distance from the take's median; inf unknown."""
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(width), np.abs(width / median - 1), np.inf)


def fix_swaps(
    views: Views, *, max_error_px: float, max_width_dev: float | None = None
) -> np.ndarray:
    """(C, T, J) bool: where camera c's labels of a left/right pair are exchanged (Pose2Sim's
    retry), because that halves the pair's reprojection error where the pair reprojects worse
    than `max_error_px` — or, for the shoulders and hips (`RIGID`, a constant distance apart),
    because it brings their distance back to the take's median where it was off by more than
    `max_width_dev` (a swap two cameras agree on: their epipolar lines run through both points,
    so the error stays small, but the points land at a wrong depth).

    Where several cameras' exchanges would do, the one whose own labels jumped is taken
    (`_jumped_labels`): with two cameras exchanging either gives the same points, and only one
    of them is right (Demo_SinglePerson cam02 labels the whole body the wrong way round in
    0.5 s of its 1.7 s; exchanging cam01's labels instead mirrored the 3D). Rounds repeat
    while some exchange is taken, so two cameras can be exchanged in one frame; an exchange
    once kept stays."""
    obs, w = views.normalised.copy(), views.weights.copy()
    swapped = np.zeros(w.shape, bool)
    for name, jl in _I.items():
        other = mirror(name)
        if not name.startswith("left_") or other is None:
            continue
        jr = _I[other]
        base, width = _pair_fit(Views(obs, w, views.extrinsics, views.focals), jl, jr)
        rigid = max_width_dev is not None and name in RIGID
        finite = width[np.isfinite(width) & (base <= max_error_px)]
        median = float(np.median(finite)) if finite.size else float("nan")
        check_width = rigid and np.isfinite(median)
        for _ in range(len(obs)):
            bad = base > 2 * max_error_px
            if check_width:
                bad |= _width_dev(width, median) > max_width_dev
            good = ~bad & np.isfinite(base)
            trials = []
            for c in range(len(obs)):
                both = bad & (w[c, :, jl] > 0) & (w[c, :, jr] > 0)
                trial = Views(obs.copy(), w.copy(), views.extrinsics, views.focals)
                for a, b in ((jl, jr), (jr, jl)):
                    trial.normalised[c, :, a], trial.weights[c, :, a] = obs[c, :, b], w[c, :, b]
                err, trial_width = _pair_fit(trial, jl, jr)
                take = both & (err < 0.5 * base)
                if check_width:
                    closer = _width_dev(trial_width, median) < 0.5 * _width_dev(width, median)
                    take |= both & closer & (err <= 2 * max_error_px)  # and it still fits
                jump = (
                    _jumped_labels(obs[c, :, [jl, jr]], w[c, :, [jl, jr]] > 0, good)
                    if take.any()
                    else 0.0
                )
                trials.append((np.where(take, jump, -np.inf), err, trial_width))
            score = np.stack([t[0] for t in trials])  # (C, T)
            best = score.argmax(axis=0)
            chosen = np.isfinite(score.max(axis=0))
            if not chosen.any():
                break
            for c, (_, err, trial_width) in enumerate(trials):
                take = chosen & (best == c)
                swapped[c, take, jl] ^= True
                swapped[c, take, jr] ^= True
                obs[c, take, jl], obs[c, take, jr] = obs[c, take, jr], obs[c, take, jl]
                w[c, take, jl], w[c, take, jr] = w[c, take, jr], w[c, take, jl]
                base, width = np.where(take, err, base), np.where(take, trial_width, width)
    return swapped


def _jumped_labels(pair: np.ndarray, seen: np.ndarray, good: np.ndarray) -> np.ndarray:
    """(T,) how much nearer one camera's two labels of a pair `pair (2, T, 2)` (seen `(2, T)`)
    come to their positions in the nearest frame where the pair is not in doubt (`good (T,)`)
    when exchanged: > 0 where this camera's labels jumped to the other side; 0 where no such
    frame is known."""
    T = pair.shape[1]
    ref = np.flatnonzero(good & seen.all(axis=0))
    if not ref.size:
        return np.zeros(T)
    t = np.arange(T)
    # the nearest reference frame of each frame (searchsorted: a long take's T × T won't fit)
    i = np.searchsorted(ref, t)
    lo, hi = ref[np.clip(i - 1, 0, len(ref) - 1)], ref[np.clip(i, 0, len(ref) - 1)]
    near = np.where(np.abs(t - lo) <= np.abs(hi - t), lo, hi)
    a, b = pair[0], pair[1]
    keep = np.linalg.norm(a - a[near], axis=-1) + np.linalg.norm(b - b[near], axis=-1)
    cross = np.linalg.norm(b - a[near], axis=-1) + np.linalg.norm(a - b[near], axis=-1)
    return np.nan_to_num(keep - cross, nan=0.0)


def relabel(values: np.ndarray, mirrored: np.ndarray) -> np.ndarray:
    """`values (C, T, J, ...)` with camera c's joint j taken from its mirror joint where
    `mirrored (C, T, J)`."""
    out = values.copy()
    out[mirrored] = values[:, :, MIRROR][mirrored]
    return out


def untangle(points: np.ndarray) -> np.ndarray:
    """(T, J) bool: frames where a left/right pair of the 3D pose `points (T, J, 3)` is to be
    exchanged so that both tracks stay continuous.

    With two cameras a swap is ambiguous: exchanging either camera's labels gives the same
    point pair, and only one of the two labellings is right. Each pair is followed frame by
    frame (from its last known positions); a frame is exchanged when the crossed assignment
    is less than half as far. Where most frames would be exchanged, the reverse is meant.
    """
    T = len(points)
    out = np.zeros(points.shape[:2], bool)
    for name, jl in _I.items():
        other = mirror(name)
        if not name.startswith("left_") or other is None:
            continue
        jr = _I[other]
        flip = np.zeros(T, bool)
        last = [np.full(3, np.nan), np.full(3, np.nan)]  # left, right as labelled so far
        for t in range(T):
            a, b = points[t, jl], points[t, jr]
            same = np.nansum([np.linalg.norm(a - last[0]), np.linalg.norm(b - last[1])])
            cross = np.nansum([np.linalg.norm(b - last[0]), np.linalg.norm(a - last[1])])
            flip[t] = cross < 0.5 * same
            if flip[t]:
                a, b = b, a
            last = [a if np.isfinite(a).all() else last[0], b if np.isfinite(b).all() else last[1]]
        known = np.isfinite(points[:, [jl, jr]]).all(axis=(1, 2))
        if flip[known].mean() > 0.5 if known.any() else False:
            flip = ~flip
        out[flip, jl] = out[flip, jr] = True
    return out


def _median_length(points: np.ndarray, a: int, b: int) -> float:
    length = np.linalg.norm(points[:, a] - points[:, b], axis=-1)
    length = length[np.isfinite(length)]
    return float(np.median(length)) if length.size else float("nan")


def _track_reference(track: np.ndarray, trusted: np.ndarray) -> np.ndarray:
    """(T, 3) running median of the trusted points of one joint's track (NaN where none)."""
    t = np.where(trusted[:, None], track, np.nan)
    half = _TRACK_WINDOW // 2
    padded = np.pad(t, ((half, half), (0, 0)), constant_values=np.nan)
    windows = np.lib.stride_tricks.sliding_window_view(padded, _TRACK_WINDOW, axis=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an unseen stretch's median is NaN
        return np.nanmedian(windows, axis=-1)


def _candidates(
    views: Views, t: np.ndarray, j: int, jm: int | None, max_error_px: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """RANSAC candidates for points (t, j): (K, n, 3) points, (K, n) mean error, (K, C, n) bool
    cameras used, (K, C, n) bool mirrored label used."""
    C = views.normalised.shape[0]
    labels = [j] if jm is None else [j, jm]
    # (L, C, n, 2) observations and (L, C, n) weights per label choice
    obs = np.stack([views.normalised[:, t, lab] for lab in labels])
    wts = np.stack([views.weights[:, t, lab] for lab in labels])
    pts, errs, cams, mirrored = [], [], [], []
    for c1, c2 in itertools.combinations(range(C), 2):
        for l1, l2 in itertools.product(range(len(labels)), repeat=2):
            w = np.zeros((C, t.size))
            o = np.full((C, t.size, 2), np.nan)
            w[c1], o[c1] = wts[l1, c1], obs[l1, c1]
            w[c2], o[c2] = wts[l2, c2], obs[l2, c2]
            seed = dlt(o, views.extrinsics, weights=w)
            # Cameras that agree with the seed join it, with whichever label agrees better.
            e = np.stack(
                [
                    reprojection_errors(
                        seed, obs[lab], extrinsics=views.extrinsics, focals=views.focals
                    )
                    for lab in range(len(labels))
                ]
            )
            e = np.where(wts > 0, np.nan_to_num(e, nan=np.inf), np.inf)
            choice = e.argmin(axis=0)  # (C, n)
            agree = np.take_along_axis(e, choice[None], 0)[0] <= max_error_px
            agree[[c1, c2]] = wts[l1, c1] > 0, wts[l2, c2] > 0
            choice[c1], choice[c2] = l1, l2
            o2 = np.take_along_axis(obs, choice[None, ..., None], 0)[0]
            w2 = np.where(agree, np.take_along_axis(wts, choice[None], 0)[0], 0.0)
            p = dlt(o2, views.extrinsics, weights=w2)
            err = reprojection_errors(p, o2, extrinsics=views.extrinsics, focals=views.focals)
            used = w2 > 0
            mean = np.where(used, np.nan_to_num(err, nan=np.inf), 0).sum(0) / np.maximum(
                used.sum(0), 1
            )
            pts.append(p)
            errs.append(np.where(np.isfinite(p).all(-1), mean, np.inf))
            cams.append(used)
            mirrored.append(used & (choice == 1))
    return np.stack(pts), np.stack(errs), np.stack(cams), np.stack(mirrored)


def _bone_dev(cand: np.ndarray, refs: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """(K, n) median relative deviation of the bones from candidates `cand (K, n, 3)` to the
    reference joints `refs (n, R, 3)` from their take lengths `lengths (R,)`; 0 where no
    reference is known (a median: one wrong reference does not condemn a torso joint)."""
    if not len(lengths):
        return np.zeros(cand.shape[:2])
    d = np.linalg.norm(cand[:, :, None] - refs[None], axis=-1) / lengths - 1  # (K, n, R)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # no reference known: NaN → 0
        return np.nan_to_num(np.nanmedian(np.abs(d), axis=-1), nan=0.0)


def make_consistent(
    points: np.ndarray,
    error: np.ndarray,
    *,
    used: np.ndarray,
    views: Views,
    max_error_px: float,
    max_bone_dev: float,
    max_jump: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, Cleaning]:
    """Find and solve again the points that disagree with their bone or track (module doc).

    points (T, J, 3), error (T, J), used (C, T, J): the DLT with exclusion; views: its input.
    max_bone_dev: largest relative deviation of a bone from the take's median length.
    max_jump: largest distance, in shoulder widths, from the running median of the track.
    A candidate reprojecting worse than `max_error_px` is never taken.
    Returns points, error, used, `mirrored (C, T, J)` (where a camera's mirror-joint
    observation was chosen for the joint, see `relabel`) and the counts.
    """
    points, error, used = points.copy(), error.copy(), used.copy()
    mirrored = np.zeros(used.shape, bool)
    width = _median_length(points, _I["left_shoulder"], _I["right_shoulder"])
    if not np.isfinite(width):
        return points, error, used, mirrored, Cleaning()
    suspects = resolved = rejected = 0
    for name, parents in PARENTS.items():
        j = _I[name]
        refs = [_I[p] for p in parents]
        lengths = np.array([_median_length(points, j, p) for p in refs])
        finite = np.isfinite(points[:, j]).all(-1)
        ref = _track_reference(points[:, j], finite)
        with np.errstate(invalid="ignore"):
            off_track = np.linalg.norm(points[:, j] - ref, axis=-1) / width > max_jump
            dev = _bone_dev(points[:, j][None], points[:, refs], lengths)[0]  # (T,)
            bad = finite & (off_track | (dev > max_bone_dev))
        if not bad.any():
            continue
        t = np.flatnonzero(bad)
        suspects += t.size
        jm_name = mirror(name)
        jm = _I[jm_name] if jm_name is not None else None
        cand, cerr, ccams, cmir = _candidates(views, t, j, jm, max_error_px)
        # Fit to the track (its running median without the suspects) and to the bones.
        ref = _track_reference(points[:, j], finite & ~bad)[t]
        jump_c = np.linalg.norm(cand - ref[None], axis=-1) / width
        jump_c = np.where(np.isfinite(jump_c), jump_c, 0.0)
        dev_c = _bone_dev(cand, points[t][:, refs], lengths)
        cost = cerr / max_error_px + jump_c / max_jump + dev_c / max_bone_dev
        cost -= 0.25 * ccams.sum(axis=1)  # more cameras agreeing: a better-founded point
        cost = np.where(np.isfinite(cerr) & (cerr <= max_error_px), cost, np.inf)
        best = cost.argmin(axis=0)
        n = np.arange(t.size)
        ok = (
            np.isfinite(cost[best, n])
            & (jump_c[best, n] <= max_jump)
            & (dev_c[best, n] <= max_bone_dev)
        )
        good, lost = t[ok], t[~ok]
        points[good, j] = cand[best[ok], n[ok]]
        error[good, j] = cerr[best[ok], n[ok]]
        used[:, good, j] = ccams[best[ok], :, n[ok]].T
        mirrored[:, good, j] = cmir[best[ok], :, n[ok]].T
        points[lost, j], error[lost, j], used[:, lost, j] = np.nan, np.nan, False
        resolved += good.size
        rejected += lost.size
    log.debug(
        "consistency: %d suspects, %d solved again, %d rejected", suspects, resolved, rejected
    )
    return points, error, used, mirrored, Cleaning(0, suspects, resolved, rejected)


# The face keypoints BlazePose guesses when it sees the back of the head (the ears stay: they
# are seen from behind too, and they alone give the head's yaw).
FACE = [_I[j] for j in ("nose", "left_eye", "right_eye")]
TORSO = [_I[j] for j in _TORSO]  # the order `facing` takes


def facing(torso: np.ndarray, centers: np.ndarray) -> np.ndarray:
    """(C, T) cosine between the torso's forward direction and the direction to each camera:
    1 = the camera sees the chest, −1 = the back. NaN where the torso is unknown.

    torso (T, 4, 3): left shoulder, right shoulder, left hip, right hip (world);
    centers (C, 3): the cameras' optical centres (world).
    """
    ls, rs, lh, rh = (torso[:, k] for k in range(4))
    # The body frame's forward, its left taken across the shoulders and hips together.
    across = (ls + lh) / 2 - (rs + rh) / 2
    to_cam = centers[:, None] - torso.mean(axis=1)[None]
    with np.errstate(invalid="ignore", divide="ignore"):
        forward = frame_from(across, torso_vectors(ls, rs, left_hip=lh, right_hip=rh)[1])[0]
        return np.einsum("ti,cti->ct", forward, to_cam) / (
            np.linalg.norm(forward, axis=-1)[None] * np.linalg.norm(to_cam, axis=-1)
        )


def unseen_face(
    confidence: np.ndarray, back: np.ndarray, *, min_confidence: float, min_cameras: int
) -> np.ndarray:
    """(C, T, J) bool: the nose and eye observations to ignore — those of cameras that see the
    person's back (`back (C, T)`), where at least `min_cameras` cameras facing the person saw
    the same point (else the guess is all there is, and it stays). confidence (C, T, J)."""
    seen = np.nan_to_num(confidence[:, :, FACE]) >= min_confidence
    front = (seen & ~back[..., None]).sum(axis=0) >= min_cameras  # (T, F)
    drop = np.zeros(confidence.shape, bool)
    drop[:, :, FACE] = seen & back[..., None] & front[None]
    return drop
