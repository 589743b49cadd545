"""Corruption toolkit: inject typical pose-estimation failures into a real take's arrays.

Used by the tests and `benchmarks/qc.py` to measure what the QC catches. Every function is pure
(returns new arrays) and seeded. Corruptions act on the video-rate pose arrays, the 2D keypoints
`pose2d_keypoints (T, K, 3)` and the 3D joints `pose3d_joints (T, 17, 3)` on the same frames,
as a failing detector would; `rederive` then recomputes the raw angles from the corrupted 3D
joints and the processed 100 Hz angles from those, exactly as the builder does. Corrupting only
the raw angles is possible too (`target="raw_angles"`); `rederive(..., from_pose=False)` then
re-processes them.

Kinds and what their strength means (sizes are in shoulder widths of each array's own units,
so the same strength hits pixels and metres alike):

- "spikes":  one keypoint (an elbow or wrist) jumps away for one frame, once per started
             second; strength = jump size in shoulder widths.
- "jitter":  independent Gaussian noise on every upper-body keypoint of every frame;
             strength = noise std in shoulder widths.
- "frozen":  the pose is held (repeated exactly) over one segment; strength = its share of the take.
- "dropout": keypoints missing (NaN, confidence 0) over one segment; strength = its share.
- "swap":    left and right elbows and wrists exchanged over `strength` short segments
             (0.1–0.3 s each), as detectors do when a person is seen from behind.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from gesturebank.config import ProcessingConfig
from gesturebank.filters import butter_lowpass, interpolate_at
from gesturebank.robot import pepper
from gesturebank.robot.retarget import pepper_angles
from gesturebank.skeletons import COCO17, get_skeleton

KINDS = ("spikes", "jitter", "frozen", "dropout", "swap")
Arrays = dict[str, np.ndarray]

_ARMS = ("left_elbow", "left_wrist", "right_elbow", "right_wrist")
_UPPER = ("nose", "left_shoulder", "right_shoulder", *_ARMS, "left_hip", "right_hip")
_PAIRS = (("left_elbow", "right_elbow"), ("left_wrist", "right_wrist"))
# Video-rate arrays (first axis = video frame) and 100 Hz arrays (first axis = `times`).
_VIDEO_RATE = (
    "raw_angles",
    "timestamps",
    "pose2d_keypoints",
    "pose2d_timestamps",
    "pose2d_world",
    "pose3d_joints",
    "pose3d_confidence",
    "pose3d_timestamps",
)
_CLOCK_RATE = ("angles", "angles01", "audio", "times")


def window(arrays: Mapping[str, np.ndarray], t0: float, t1: float) -> Arrays:
    """The part of a take between `t0` and `t1` seconds (take time): 100 Hz arrays with
    t0 <= times < t1, video-rate arrays with t0 <= timestamps < t1; the rest unchanged."""
    out = {k: np.asarray(v) for k, v in arrays.items()}
    ts = np.asarray(arrays["timestamps"])
    keep_v = (ts >= t0) & (ts < t1)
    times = np.asarray(arrays["times"])
    keep_c = (times >= t0) & (times < t1)
    for k in _VIDEO_RATE:
        if k in out:
            out[k] = out[k][keep_v]
    for k in _CLOCK_RATE:
        if k in out:
            out[k] = out[k][keep_c]
    return out


def _mirror_perm(skeleton: str) -> np.ndarray:
    """Index permutation exchanging every left_/right_ (and _left/_right) keypoint name."""
    names = get_skeleton(skeleton).joints
    idx = get_skeleton(skeleton).index

    def other(n: str) -> str:
        for a, b in (("left", "right"), ("right", "left")):
            if a in n:
                return n.replace(a, b)
        return n

    return np.array([idx[other(n)] for n in names])


def mirror(arrays: Mapping[str, np.ndarray]) -> Arrays:
    """The take's mirror image (a clean variant, not a corruption): 2D x → width − x, 3D x → −x,
    and left/right keypoints exchanged, so the result is the real motion of a mirrored person.
    Angles must be re-derived (`rederive`)."""
    out = {k: np.array(v, copy=True) for k, v in arrays.items()}
    if "pose2d_keypoints" in out:
        kp = out["pose2d_keypoints"][:, _mirror_perm(str(out["pose2d_skeleton"]))]
        kp[..., 0] = float(np.asarray(out["pose2d_image_size"])[0]) - kp[..., 0]
        out["pose2d_keypoints"] = kp
        if "pose2d_world" in out:
            world = out["pose2d_world"][:, _mirror_perm(str(out["pose2d_skeleton"]))]
            world[..., 0] *= -1
            out["pose2d_world"] = world
    if "pose3d_joints" in out:
        perm = _mirror_perm(COCO17.name)
        joints = out["pose3d_joints"][:, perm]
        joints[..., 0] *= -1
        out["pose3d_joints"] = joints
        if "pose3d_confidence" in out:
            out["pose3d_confidence"] = out["pose3d_confidence"][:, perm]
    return out


# --------------------------------------------------------------------------------------------------
# Where the keypoints are


def _index(skeleton: str, names: tuple[str, ...]) -> np.ndarray:
    idx = get_skeleton(skeleton).index
    return np.array([idx[n] for n in names])


def _targets(arrays: Mapping[str, np.ndarray], target: str) -> list[tuple[str, np.ndarray]]:
    """(array name, skeleton index of `_UPPER`) of each array to corrupt."""
    if target == "raw_angles":
        return [("raw_angles", np.arange(len(pepper.JOINTS)))]
    found = []
    if "pose2d_keypoints" in arrays:
        found.append(("pose2d_keypoints", _index(str(arrays["pose2d_skeleton"]), _UPPER)))
    if "pose3d_joints" in arrays:
        found.append(("pose3d_joints", _index(COCO17.name, _UPPER)))
    return found


def _shoulder_width(points: np.ndarray, idx: np.ndarray) -> float:
    """Median distance between the shoulders (`_UPPER` positions 1, 2) of `points (T, K, C)`."""
    d = np.linalg.norm(points[:, idx[1]] - points[:, idx[2]], axis=-1)
    d = d[np.isfinite(d)]
    return float(np.median(d)) if len(d) else 1.0


def _coords(name: str) -> slice:
    """Coordinate channels of an array: x, y of keypoints (not the confidence), else all."""
    return slice(0, 2) if name == "pose2d_keypoints" else slice(None)


def _segment(rng: np.random.Generator, n: int, share: float) -> slice:
    length = int(np.clip(round(share * n), 1, n))
    start = int(rng.integers(0, n - length + 1))
    return slice(start, start + length)


# --------------------------------------------------------------------------------------------------
# The corruptions


def corrupt(
    arrays: Mapping[str, np.ndarray],
    kind: str,
    strength: float,
    seed: int = 0,
    *,
    target: str = "pose",
) -> Arrays:
    """A copy of `arrays` with one corruption `kind` (see the module docstring) injected into the
    pose arrays (`target="pose"`: 2D keypoints and 3D joints on the same frames) or only into
    `raw_angles` (`target="raw_angles"`, strengths then in radians instead of shoulder widths)."""
    if kind not in KINDS:
        raise ValueError(f"unknown corruption {kind!r}; known: {', '.join(KINDS)}")
    rng = np.random.default_rng(seed)
    out = {k: np.array(v, copy=True) for k, v in arrays.items()}
    ts = np.asarray(out["timestamps"], dtype=np.float64)
    n = len(ts)
    duration = float(ts[-1] - ts[0]) if n > 1 else 0.0
    targets = _targets(out, target)

    if kind == "spikes":
        frames = rng.choice(np.arange(1, n - 1), size=max(1, int(np.ceil(duration))), replace=False)
        which = rng.integers(3, 7, size=len(frames))  # an elbow or a wrist in `_UPPER`
        dirs = rng.normal(size=(len(frames), 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        for name, idx in targets:
            a, c = out[name], _coords(name)
            if target == "raw_angles":
                joint = rng.integers(0, a.shape[1], size=len(frames))
                a[frames, joint] += strength * np.sign(dirs[:, 0])
                continue
            size = strength * _shoulder_width(a[..., c], idx)
            dim = a[..., c].shape[-1]
            for f, w, d in zip(frames, which, dirs, strict=True):
                a[f, idx[w], c] += size * d[:dim] / np.linalg.norm(d[:dim])
    elif kind == "jitter":
        for name, idx in targets:
            a, c = out[name], _coords(name)
            if target == "raw_angles":
                a += rng.normal(scale=strength, size=a.shape).astype(a.dtype)
                continue
            size = strength * _shoulder_width(a[..., c], idx)
            noise = rng.normal(scale=size, size=a[:, idx, c].shape)
            a[:, idx, c] += noise.astype(a.dtype)
    elif kind == "frozen":
        seg = _segment(rng, n, strength)
        for name, _ in targets:
            out[name][seg] = out[name][seg.start]
        if target == "pose" and "pose3d_confidence" in out:
            out["pose3d_confidence"][seg] = out["pose3d_confidence"][seg.start]
    elif kind == "dropout":
        seg = _segment(rng, n, strength)
        for name, _ in targets:
            out[name][seg] = np.nan
            if name == "pose2d_keypoints":
                out[name][seg, :, 2] = 0.0
        if target == "pose" and "pose3d_confidence" in out:
            out["pose3d_confidence"][seg] = 0.0
    else:  # swap
        for _ in range(int(strength)):
            seg = _segment(rng, n, rng.uniform(0.1, 0.3) / max(duration, 1e-9))
            for name, _ in targets:
                a = out[name]
                if target == "raw_angles":
                    a[seg] = _mirror_angles(a[seg])
                    continue
                skel = str(out["pose2d_skeleton"]) if name == "pose2d_keypoints" else COCO17.name
                for left, right in _PAIRS:
                    li, ri = _index(skel, (left, right))
                    a[seg, li], a[seg, ri] = a[seg, ri].copy(), a[seg, li].copy()
    return out


def _mirror_angles(angles: np.ndarray) -> np.ndarray:
    """Pepper angles `(N, 11)` of the left/right-exchanged arms (roll and yaw change sign)."""
    j = pepper.INDEX
    out = np.array(angles, copy=True)
    for left, right, sign in (
        ("LShoulderRoll", "RShoulderRoll", -1),
        ("LShoulderPitch", "RShoulderPitch", 1),
        ("LElbowRoll", "RElbowRoll", -1),
        ("LElbowYaw", "RElbowYaw", -1),
    ):
        out[:, j[left]], out[:, j[right]] = sign * angles[:, j[right]], sign * angles[:, j[left]]
    return out


# --------------------------------------------------------------------------------------------------
# Re-deriving the angles


def rederive(
    arrays: Mapping[str, np.ndarray],
    processing: ProcessingConfig | None = None,
    profile: pepper.RobotProfile | str = "pepper-1.7",
    *,
    from_pose: bool = True,
) -> Arrays:
    """Recompute `raw_angles` from `pose3d_joints` (unless `from_pose` is False) and `angles`,
    `angles01` from those on the take's own 100 Hz clock `times`, as the builder does:
    interpolation (gaps up to `max_gap_s`), zero-phase Butterworth, clamp, normalise."""
    p = processing or ProcessingConfig()
    prof = pepper.load_profile(profile) if isinstance(profile, str) else profile
    out = dict(arrays)
    if from_pose:
        out["raw_angles"] = pepper_angles(np.asarray(arrays["pose3d_joints"])).astype(np.float32)
    raw = np.asarray(out["raw_angles"], dtype=np.float64)
    angles, _ = interpolate_at(raw, out["timestamps"], out["times"], max_gap_s=p.max_gap_s)
    smooth = butter_lowpass(angles, p.rate_hz, p.cutoff_hz, p.butter_order)
    clamped = pepper.clamp(smooth, prof)
    out["angles"] = clamped.astype(np.float32)
    out["angles01"] = pepper.normalise(clamped, prof).astype(np.float32)
    return out
