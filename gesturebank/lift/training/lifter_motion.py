"""Upper-body gesture motion made up from scratch for the `learned` lifter's training (issue 39:
a net trained on one take learns that take; this covers the upper body's range by construction).

A person of random proportions (`Proportions`, in units of the neck → mid-hip length) moves every
part on its own schedule (`_channel`): holds, strokes (minimum-jerk moves to a new target), beats
(small fast back-and-forth) and fast swings, each arm independently or, now and then, mirroring
the other (a two-handed gesture); shoulders shrug and go forward, the torso leans, bends sideways
and turns over the hips, the head turns, nods and tilts, the whole body sways and turns on the
spot. The arm's targets are drawn half from the space in front of the body where speakers gesture
and half from the whole anatomical range, hands behind the back and on the chest included.

`gesture_take(rng, frames)` gives COCO-17 joints (frames, 17, 3), metres, z up, at RATE_HZ.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

import numpy as np

from gesturebank.lift.learned.features import RATE_HZ

# (low, high) of each proportion, neck → mid-hip lengths (test.bvh's person: shoulders 0.35,
# hips 0.21, upper arm 0.67, forearm 0.51, head 0.39 forward of the neck)
SPINE_M = (0.40, 0.60)
SHOULDER_HALF = (0.28, 0.42)
HIP_HALF = (0.16, 0.26)
UPPER_ARM = (0.55, 0.75)
FOREARM = (0.45, 0.60)
HEAD_SIZE = (0.85, 1.15)
HEAD_FORWARD = (0.10, 0.40)  # how far the head sits forward of the shoulders (posture)
# the face in the head's frame (forward, left, up) for HEAD_SIZE 1, before HEAD_FORWARD
_FACE = np.array([(0.20, 0.0, 0.43), (0.16, 0.07, 0.50), (0.16, -0.07, 0.50),
                  (0.0, 0.15, 0.47), (0.0, -0.15, 0.47)])  # fmt: skip

# each arm channel: (anatomical range, where speakers gesture), degrees. Upper arm: raise from
# hanging (0) to overhead; swing about the body (0 out to the side, 90 forward, >90 across the
# front, <0 behind); elbow bend; the forearm's turn about the upper arm (0 bends it forward, +90
# inwards across the body, −90 outwards).
ARM_RANGES = {
    "raise": ((0.0, 170.0), (15.0, 95.0)),
    "swing": ((-60.0, 140.0), (20.0, 110.0)),
    "bend": ((0.0, 150.0), (30.0, 120.0)),
    "turn": ((-90.0, 110.0), (-20.0, 80.0)),
}
REST = {"raise": 5.0, "swing": 30.0, "bend": 15.0, "turn": 20.0}  # arms hanging
BEHIND_MAX_RAISE_DEG = 60.0  # an arm behind the body cannot rise further


@dataclass(frozen=True)
class Proportions:
    spine_m: float
    shoulder_half: float
    hip_half: float
    upper_arm: float
    forearm: float
    head_size: float
    head_forward: float

    @classmethod
    def sample(cls, rng: np.random.Generator) -> Proportions:
        return cls(*(float(rng.uniform(*r)) for r in (SPINE_M, SHOULDER_HALF, HIP_HALF,
                   UPPER_ARM, FOREARM, HEAD_SIZE, HEAD_FORWARD)))  # fmt: skip


@cache
def _min_jerk(n: int) -> np.ndarray:
    """(n, 1) a minimum-jerk move's progress over n frames, ending at 1."""
    tau = np.linspace(0.0, 1.0, n + 1)[1:, None]
    return tau**3 * (10 - 15 * tau + 6 * tau**2)


def _channel(
    rng: np.random.Generator, frames: int, draw: Callable[[], np.ndarray], *, tempo: float
) -> np.ndarray:
    """(frames, D) a gesture-like trajectory: a chain of phases, each a hold, a stroke, a beat
    run or a swing, towards targets from `draw()` (D,); `tempo` > 1 makes the phases longer."""
    out: list[np.ndarray] = []
    here, made = draw(), 0
    while made < frames:
        kind = rng.choice(4, p=(0.3, 0.4, 0.15, 0.15))
        if kind == 2:  # beats: small quick strokes about the current place and back
            amp = rng.uniform(0.05, 0.3) * (draw() - here)
            n = max(2, int(rng.uniform(0.1, 0.3) * tempo * RATE_HZ))
            there = _min_jerk(n) * amp
            run = np.concatenate([there, amp - there] * int(rng.integers(2, 7)))
            out.append(here + run)
            made += len(run)
            continue
        if kind == 0:  # hold, drifting a little
            n = int(rng.uniform(0.15, 1.5) * tempo * RATE_HZ) + 1
            target = here + rng.normal(0.0, 0.03, here.shape) * np.abs(here).max()
        elif kind == 1:  # a stroke
            n = int(rng.uniform(0.2, 0.8) * tempo * RATE_HZ) + 2
            target = draw()
        else:  # a fast swing far across the range
            n = int(rng.uniform(0.15, 0.35) * tempo * RATE_HZ) + 2
            target = draw()
        out.append(here + _min_jerk(n) * (target - here))
        here, made = target, made + n
    return np.concatenate(out)[:frames]


def _arm_target(rng: np.random.Generator) -> np.ndarray:
    """(raise, swing, bend, turn) degrees: the rest pose, the gesture space or anywhere."""
    u = rng.random()
    if u < 0.15:
        v = np.array([REST[k] for k in ARM_RANGES]) + rng.normal(0.0, 8.0, 4)
    else:
        which = 1 if u < 0.55 else 0
        v = np.array([rng.uniform(*r[which]) for r in ARM_RANGES.values()])
    if v[1] < -15.0:
        v[0] = min(v[0], BEHIND_MAX_RAISE_DEG)
    return v


def _rot(axis: int, angle: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations by `angle` (T,) radians about the x (0), y (1) or z (2) axis."""
    c, s = np.cos(angle), np.sin(angle)
    r = np.zeros((len(angle), 3, 3))
    i, j = (axis + 1) % 3, (axis + 2) % 3
    r[:, axis, axis] = 1.0
    r[:, i, i], r[:, j, j], r[:, i, j], r[:, j, i] = c, c, -s, s
    return r


def gesture_take(rng: np.random.Generator, frames: int) -> np.ndarray:
    """(frames, 17, 3) COCO-17 joints, metres, z up, facing +x at the start (module doc)."""
    p = Proportions.sample(rng)
    tempo = rng.uniform(0.6, 1.5)  # a calm or an excited speaker
    deg = np.deg2rad

    def slow(lo: float, hi: float, k: int = 1) -> np.ndarray:
        return _channel(rng, frames, lambda: rng.uniform(lo, hi, k), tempo=2.0 * tempo)

    turn = deg(slow(-40.0, 40.0)[:, 0])  # the body turning on the spot
    sway = slow(-0.15, 0.15, 3) * np.array([1.0, 1.0, 0.15])  # stepping about (spine lengths)
    lean = deg(slow(-10.0, 35.0)[:, 0]) * (rng.random() < 0.7)
    side = deg(slow(-15.0, 15.0)[:, 0])
    twist = deg(slow(-30.0, 30.0)[:, 0])
    shrug = _channel(rng, frames, lambda: rng.uniform(-0.03, 0.15, 2) * (rng.random() < 0.5),
                     tempo=tempo)  # fmt: skip
    forward_sh = slow(-0.05, 0.10, 2)
    head = deg(
        _channel(rng, frames, lambda: rng.uniform((-60, -25, -20), (60, 35, 20)), tempo=1.5 * tempo)
    )  # fmt: skip  (yaw, pitch down, roll)

    hip_rot = _rot(2, turn)
    pelvis = sway * p.spine_m
    torso_rot = hip_rot @ _rot(2, twist) @ _rot(1, lean) @ _rot(0, side)
    fwd, left, up = (torso_rot[:, :, k] for k in range(3))
    j = np.zeros((frames, 17, 3))
    s = p.spine_m
    for k, sign in ((11, 1.0), (12, -1.0)):
        j[:, k] = pelvis + sign * p.hip_half * s * hip_rot[:, :, 1]
        j[:, k + 2] = j[:, k] + np.array([0.05, 0.0, -0.85]) * s  # knees, ankles: standing
        j[:, k + 4] = j[:, k + 2] + np.array([-0.05, 0.0, -0.8]) * s
    neck = pelvis + s * up
    for k, sign in ((5, 1.0), (6, -1.0)):
        col = 0 if sign > 0 else 1
        j[:, k] = neck + s * (sign * p.shoulder_half * left + shrug[:, col, None] * up
                              + forward_sh[:, col, None] * fwd)  # fmt: skip
    head_rot = torso_rot @ _rot(2, head[:, 0]) @ _rot(1, head[:, 1]) @ _rot(0, head[:, 2])
    base = j[:, 5:7].mean(1) + s * p.head_forward * fwd
    j[:, :5] = base[:, None] + s * p.head_size * np.einsum("tij,fj->tfi", head_rot, _FACE)

    mirrored = rng.random() < 0.3  # a two-handed gesture: the right arm mirrors the left
    left_arm = deg(_channel(rng, frames, lambda: _arm_target(rng), tempo=tempo))
    for side_name, sh, el, wr in (("left", 5, 7, 9), ("right", 6, 8, 10)):
        if side_name == "left" or not mirrored:
            angles = (
                left_arm
                if side_name == "left"
                else deg(_channel(rng, frames, lambda: _arm_target(rng), tempo=tempo))
            )
        else:
            angles = left_arm + deg(rng.normal(0.0, 5.0, 4))
        out = left if side_name == "left" else -left
        raise_, swing, bend, fore_turn = (angles[:, k, None] for k in range(4))
        upper = -np.cos(raise_) * up + np.sin(raise_) * (np.cos(swing) * out + np.sin(swing) * fwd)
        ref = fwd + np.sin(raise_) * up  # forward (up for an arm raised forward), ⟂ the arm
        ref = ref - np.sum(ref * upper, -1, keepdims=True) * upper
        ref /= np.linalg.norm(ref, axis=-1, keepdims=True) + 1e-9
        inward = np.cross(upper, ref) * (1.0 if side_name == "left" else -1.0)
        toward = np.cos(fore_turn) * ref + np.sin(fore_turn) * inward
        fore = np.cos(bend) * upper + np.sin(bend) * toward
        j[:, el] = j[:, sh] + s * p.upper_arm * upper
        j[:, wr] = j[:, el] + s * p.forearm * fore
    return j
