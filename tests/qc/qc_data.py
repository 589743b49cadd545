"""Synthetic takes and datasets for the QC tests (a plain module: imported by name)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gesturebank.datasets import store
from gesturebank.qc.corrupt import rederive
from gesturebank.robot import pepper


def synthetic_take(seconds: float = 3.0, fps: float = 30.0, seed: int = 0) -> dict[str, np.ndarray]:
    """Arrays of a clean take (store layout): smooth arm motion inside the limits, through the
    robot's forward kinematics to COCO-17 joints, a frontal orthographic 2D view, angles
    re-derived as the builder does."""
    rng = np.random.default_rng(seed)
    ts = np.arange(0, seconds, 1 / fps)
    prof = pepper.load_profile()
    mid, half = (prof.lower + prof.upper) / 2, (prof.upper - prof.lower) / 2
    phase = rng.uniform(0, 2 * np.pi, 11)
    freq = rng.uniform(0.3, 0.8, 11)
    angles = pepper.neutral_pose() + 0.3 * half * np.sin(2 * np.pi * freq * ts[:, None] + phase)
    angles = np.clip(angles, mid - 0.9 * half, mid + 0.9 * half)
    joints = pepper.fk_coco17(angles).astype(np.float32)
    # knees/ankles are NaN in FK: put them under the hips so the 2D detector "sees" them
    joints[:, 13:15] = joints[:, 11:13] - [0, 0, 0.4]
    joints[:, 15:17] = joints[:, 11:13] - [0, 0, 0.8]
    xy = np.stack([640 - 400 * joints[..., 1], 360 - 400 * joints[..., 2]], axis=-1)
    kp = np.concatenate([xy, np.ones((*xy.shape[:2], 1))], axis=-1).astype(np.float32)
    times = np.arange(ts[0], ts[-1], 0.01)
    arrays = {
        "times": times,
        "timestamps": ts,
        "audio": np.zeros((len(times), 26), np.float32),
        "pose2d_keypoints": kp,
        "pose2d_timestamps": ts,
        "pose2d_skeleton": np.array("coco17"),
        "pose2d_image_size": np.array([1280, 720]),
        "pose3d_joints": joints,
        "pose3d_confidence": np.ones(joints.shape[:2], np.float32),
        "pose3d_timestamps": ts,
    }
    return rederive(arrays)


def write_synthetic_dataset(out: Path, takes: dict[str, dict[str, np.ndarray]]) -> Path:
    """A dataset folder holding `takes` (id → arrays), all marked accepted as the builder does."""
    for take_id, arrays in takes.items():
        record = store.TakeRecord(
            take_id=take_id,
            subject=take_id.split("_")[0],
            source=f"{take_id}.mp4",
            qc_status="accepted",
            config_digest="test",
            duration_s=float(arrays["times"][-1] - arrays["times"][0]),
            metrics={"duration_s": 1.0},
            n_frames=len(arrays["times"]),
        )
        store.write_take(out, record, arrays)
    store.write_manifest(out)
    store.write_dataset_json(out, {"robot_profile": "pepper-1.7", "joints": list(pepper.JOINTS)})
    return out
