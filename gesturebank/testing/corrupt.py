"""Corruption toolkit: inject typical pose-estimation failures into a real clip.

Used by the tests and `benchmarks/qc.py` to measure what the QC catches. Every function is pure
(returns a new Clip) and seeded. Corruptions act on the video-rate pose arrays, the 2D keypoints
`pose2d.keypoints (T, K, 3)` and the 3D joints `pose3d.joints (T, 17, 3)` on the same frames,
as a failing detector would *after* the repair (the QC judges what repair left); `rederive`
then recomputes the raw angles from the corrupted 3D joints and the processed 100 Hz angles from
those with the builder's own `datasets.process.process_angles`. Corrupting only the raw angles
is possible too (`target="raw_angles"`); `rederive(..., from_pose=False)` then re-processes
them.

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
from dataclasses import replace

import numpy as np

from gesturebank.clip import Clip, part_columns
from gesturebank.config import ProcessingConfig, RetargetConfig, RobotConfig
from gesturebank.datasets.head import FACE
from gesturebank.datasets.process import process_angles
from gesturebank.robot import pepper
from gesturebank.robot.retarget import angle_support, pepper_angles
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
    "valid",
    "repaired",
    "n_people",
    "change",
    "depth_confidence",
    "head_source",
)
_CLOCK_RATE = (
    "angles",
    "angles01",
    "mask",
    "audio",
    "times",
    "speech",
    "role",
    "head_roll",
    "partner_speaking",
)


def window(clip: Clip, t0: float, *, t1: float) -> Clip:
    """The part of a clip between `t0` and `t1` seconds (clip time): 100 Hz arrays with
    t0 <= times < t1, video-rate arrays with t0 <= timestamps < t1; the rest unchanged."""
    arrays = clip.to_arrays()
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
    return Clip.from_arrays(out)


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


def mirror(clip: Clip) -> Clip:
    """The clip's mirror image (a clean variant, not a corruption): 2D x → width − x, 3D x → −x,
    and left/right keypoints exchanged, so the result is the real motion of a mirrored person.
    Angles must be re-derived (`rederive`)."""
    out = {k: np.array(v, copy=True) for k, v in clip.to_arrays().items()}
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
        out["valid"] = out["valid"][:, perm]
        out["repaired"] = out["repaired"][:, perm]
    return Clip.from_arrays(out)


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
    clip: Clip,
    kind: str,
    *,
    strength: float,
    seed: int = 0,
    target: str = "pose",
) -> Clip:
    """A copy of `clip` with one corruption `kind` (see the module docstring) injected into the
    pose arrays (`target="pose"`: 2D keypoints and 3D joints on the same frames) or only into
    `raw_angles` (`target="raw_angles"`, strengths then in radians instead of shoulder widths)."""
    if kind not in KINDS:
        raise ValueError(f"unknown corruption {kind!r}; known: {', '.join(KINDS)}")
    rng = np.random.default_rng(seed)
    out = {k: np.array(v, copy=True) for k, v in clip.to_arrays().items()}
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
        if target == "pose":
            out["valid"][seg] = False  # what the repair marks as unseen
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
    return Clip.from_arrays(out)


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
    clip: Clip,
    *,
    processing: ProcessingConfig | None = None,
    profile: pepper.RobotProfile | str | None = None,
    from_pose: bool = True,
) -> Clip:
    """Recompute `raw_angles` from `pose3d.joints` (unless `from_pose` is False; masked where the
    clip's keypoints were unseen, as the builder does; the head kept where the clip read it from
    the face) and the 100 Hz angles from those with the builder's `process_angles`."""
    if isinstance(profile, pepper.RobotProfile):
        prof = profile
    else:  # a name, or None: the `robot` section's default
        prof = pepper.load_profile(profile or RobotConfig().profile)
    raw = np.array(clip.raw_angles, dtype=np.float32)
    if from_pose:
        raw = pepper_angles(clip.pose3d)
        raw[~angle_support(clip.valid)] = np.nan
        # a head read from the face mesh is not in the pose, nor the face's axes in the clip: kept
        face = np.asarray(clip.head_source) == FACE
        head = [pepper.INDEX["HeadPitch"], pepper.INDEX["HeadYaw"]]
        raw[np.ix_(face, head)] = np.asarray(clip.raw_angles)[np.ix_(face, head)]
    processed = process_angles(
        raw=raw,
        timestamps=clip.timestamps,
        clock=clip.times,
        processing=processing or ProcessingConfig(),
        retarget=RetargetConfig(),
        profile=prof,
    )
    return replace(
        clip,
        raw_angles=raw,
        angles=processed.angles,
        angles01=processed.angles01,
        mask=processed.mask,
        # the roll is the head's: unknown where the head now is (Clip's invariant)
        head_roll=np.where(
            processed.mask[:, part_columns("head")].any(axis=1), clip.head_roll, np.nan
        ).astype(np.float32),
    )
