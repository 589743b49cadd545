"""What the learned lifter's network sees and gives, shared by inference and its training.

Input, per frame: the 13 upper-body COCO-17 keypoints (nose to hips; knees and ankles are often
out of a speaker's frame) as pinhole ray coordinates ((pixel − principal point) / focal), taken
relative to the neck (mid-shoulders) and divided by the torso's size in the image (the take's
`torso_scale`: pixels per unit length at the neck's depth, a running median), plus the neck's own
ray coordinates (where the person is in the image, the perspective). A missing keypoint is
interpolated over time from the frames that have it. Sampled at `RATE_HZ`.

Output, per frame: the same 13 joints in the camera's axes (x right, y down, z forward) relative
to the neck, in units of the true neck → mid-hip length.
"""

from __future__ import annotations

import numpy as np

from gesturebank.lift.depth_sign import torso_scale
from gesturebank.skeletons import COCO17

JOINTS = COCO17.joints[:13]  # nose … right_hip
N_JOINTS = len(JOINTS)
N_FEATURES = 2 * N_JOINTS + 2
N_OUTPUTS = 3 * N_JOINTS
RATE_HZ = 30.0  # the motion capture's rate, at which the network was trained
SCALE_WINDOW_S = 1.0  # running median of the torso's image size
SHOULDERS_PER_SPINE = 0.7  # shoulder width / neck → mid-hip length of the training mocap
_I = COCO17.index
_LS, _RS, _LH, _RH = (_I[j] for j in ("left_shoulder", "right_shoulder", "left_hip", "right_hip"))


def torso_ok(uv: np.ndarray) -> np.ndarray:
    """(T,) frames whose shoulders and hips (T, 13, 2) are all known."""
    return np.isfinite(uv[:, [_LS, _RS, _LH, _RH]]).all(axis=(1, 2))


def fill_gaps(uv: np.ndarray) -> np.ndarray:
    """(T, J, 2) with each joint's missing frames interpolated linearly in time (held at the
    ends); a joint never seen is put at the neck."""
    out = np.array(uv, dtype=np.float64)
    frames = np.arange(len(out))
    for j in range(out.shape[1]):
        seen = np.isfinite(out[:, j]).all(axis=-1)
        if seen.all() or not seen.any():
            continue
        for c in range(2):
            out[:, j, c] = np.interp(frames, frames[seen], out[seen, j, c])
    neck = out[:, [_LS, _RS]].mean(axis=1)
    never = ~np.isfinite(out).all(axis=-1)
    out[never] = np.broadcast_to(neck[:, None], out.shape)[never]
    return out


def image_scale(uv: np.ndarray) -> np.ndarray:
    """(T,) the torso's size in ray units per frame of gap-free keypoints uv (T, 13, 2)."""
    neck = uv[:, [_LS, _RS]].mean(axis=1)
    lengths = {
        "spine": np.linalg.norm(neck - uv[:, [_LH, _RH]].mean(axis=1), axis=-1),
        "shoulders": np.linalg.norm(uv[:, _LS] - uv[:, _RS], axis=-1) / 2,
        "hips": np.linalg.norm(uv[:, _LH] - uv[:, _RH], axis=-1) / 2,
    }
    ok = np.isfinite(lengths["spine"]) & (lengths["spine"] > 0)
    window = max(1, round(SCALE_WINDOW_S * RATE_HZ) | 1)
    return torso_scale(lengths, ok, window=window, percentile=95.0)


def features(uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Network input (T, N_FEATURES) float32 of gap-free ray coordinates uv (T, 13, 2) at
    RATE_HZ, with the neck's ray coordinates (T, 2) and the image scale (T,) that turn the
    output back into the camera's frame (`camera_joints`)."""
    neck = uv[:, [_LS, _RS]].mean(axis=1)
    scale = image_scale(uv)
    rel = (uv - neck[:, None]) / scale[:, None, None]
    x = np.concatenate([rel.reshape(len(uv), -1), neck], axis=1)
    return x.astype(np.float32), neck, scale


def camera_joints(
    output: np.ndarray, neck: np.ndarray, *, scale: np.ndarray, shoulder_width_m: float
) -> np.ndarray:
    """(T, 13, 3) joints in the camera's frame, metres, of the network's output (T, N_OUTPUTS):
    the output's unit (a neck → mid-hip length) is `shoulder_width_m` / SHOULDERS_PER_SPINE,
    the neck put on its ray at the depth where that unit looks `scale` large."""
    rel = output.reshape(len(output), N_JOINTS, 3).astype(np.float64)
    metres = shoulder_width_m / SHOULDERS_PER_SPINE
    depth = metres / scale  # a unit length looks `scale` large at the neck's depth
    neck3d = np.concatenate([neck, np.ones((len(neck), 1))], axis=1) * depth[:, None]
    return neck3d[:, None] + rel * metres


def resample(values: np.ndarray, times: np.ndarray, *, at: np.ndarray) -> np.ndarray:
    """values (T, ...) at `times`, linearly interpolated at `at` (held at the ends); NaN stays
    where either neighbour is NaN."""
    flat = values.reshape(len(values), -1)
    idx = np.clip(np.searchsorted(times, at, side="right") - 1, 0, len(times) - 1)
    nxt = np.clip(idx + 1, 0, len(times) - 1)
    span = np.where(nxt > idx, times[nxt] - times[idx], 1.0)
    w = np.clip((at - times[idx]) / span, 0.0, 1.0)[:, None]
    out = flat[idx] * (1 - w) + flat[nxt] * w
    return out.reshape((len(at), *values.shape[1:]))
