"""The exact truth of a render, written beside its videos and read back as a `Truth`.

A render folder (`gesturebank render BVH OUT`):

    OUT/calibration.toml   the cameras (Pose2Sim/anipose layout; `load_cameras` reads it)
    OUT/videos/cam01.mp4 … one video per camera, speech muxed (a multi-camera take when ≥ 2)
    OUT/speech.wav         the same speech, 16 kHz mono (a multi-camera take's audio)
    OUT/truth.npz          the arrays below
    OUT/render.json        what was rendered (the cache key)

truth.npz: `times (T,)` s from the first frame; `joints3d (T, 17, 3)` COCO-17 world metres (the
cameras' frame) of the first figure, `figures3d (P, T, 17, 3)` of every figure; `angles (T, 11)`
Pepper radians (order `robot.pepper.JOINTS`, `retarget.pepper_angles` with the default
RetargetConfig, no limits applied); `joints2d (C, T, 17, 2)` px, the first figure projected by
each camera; `mouth (P, T)` openings; `cameras (C,)` names; `fps`, `start_s` (where in the BVH
the first frame is), `source` (the BVH file names), `look`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gesturebank.camera_files import CameraGroup, cameras_toml, load_cameras
from gesturebank.errors import InputError
from gesturebank.fileio import atomic_open
from gesturebank.skeletons import COCO17

TRUTH = "truth.npz"
CALIBRATION = "calibration.toml"
VIDEOS = "videos"
SPEECH = "speech.wav"
KEY = "render.json"


@dataclass(frozen=True, eq=False)
class Truth:
    """The arrays of truth.npz (module docstring) and the cameras of calibration.toml."""

    folder: Path
    times: np.ndarray
    joints3d: np.ndarray
    figures3d: np.ndarray
    angles: np.ndarray
    joints2d: np.ndarray
    mouth: np.ndarray
    cameras: CameraGroup
    fps: float
    start_s: float
    source: tuple[str, ...]
    look: str

    def __post_init__(self) -> None:
        t, c, j = len(self.times), len(self.cameras), len(COCO17)
        shapes = {
            "joints3d": (self.joints3d.shape, (t, j, 3)),
            "angles": (self.angles.shape, (t, 11)),
            "joints2d": (self.joints2d.shape, (c, t, j, 2)),
            "figures3d": (self.figures3d.shape[1:], (t, j, 3)),
            "mouth": (self.mouth.shape[1:], (t,)),
        }
        for name, (got, want) in shapes.items():
            if got != want:
                raise InputError(f"{self.folder / TRUTH}: {name} is {got}, expected {want}")
        if not np.isfinite(self.joints3d).all():
            raise InputError(f"{self.folder / TRUTH}: joints3d is not finite")

    @property
    def videos(self) -> tuple[Path, ...]:
        """The videos, one per camera, in the cameras' order."""
        return tuple(self.folder / VIDEOS / f"{name}.mp4" for name in self.cameras.names)

    def save(self) -> Path:
        """Write truth.npz and calibration.toml into `folder` (each atomically)."""
        with atomic_open(self.folder / CALIBRATION) as f:
            f.write(cameras_toml(self.cameras).encode())
        with atomic_open(self.folder / TRUTH) as f:
            np.savez(
                f,
                times=self.times,
                joints3d=self.joints3d,
                figures3d=self.figures3d,
                angles=self.angles,
                joints2d=self.joints2d,
                mouth=self.mouth,
                cameras=np.array(self.cameras.names),
                fps=np.float64(self.fps),
                start_s=np.float64(self.start_s),
                source=np.array(self.source),
                look=np.array(self.look),
            )
        return self.folder / TRUTH

    @classmethod
    def load(cls, folder: str | os.PathLike[str]) -> Truth:
        """The truth of a render folder; InputError naming the file when it is missing or bad."""
        root = Path(folder)
        path = root / TRUTH
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files}
        except FileNotFoundError:
            raise InputError(f"{path}: no truth here (not a `gesturebank render` folder)") from None
        except (OSError, ValueError) as exc:
            raise InputError(f"{path}: cannot read ({exc})") from None
        cameras = load_cameras(root / CALIBRATION)
        names = [str(n) for n in arrays["cameras"]]
        if names != cameras.names:
            raise InputError(f"{path}: cameras {names} differ from {root / CALIBRATION}")
        try:
            return cls(
                folder=root,
                times=arrays["times"],
                joints3d=arrays["joints3d"],
                figures3d=arrays["figures3d"],
                angles=arrays["angles"],
                joints2d=arrays["joints2d"],
                mouth=arrays["mouth"],
                cameras=cameras,
                fps=float(arrays["fps"]),
                start_s=float(arrays["start_s"]),
                source=tuple(str(s) for s in arrays["source"]),
                look=str(arrays["look"]),
            )
        except KeyError as exc:
            raise InputError(f"{path}: missing {exc.args[0]}") from None
