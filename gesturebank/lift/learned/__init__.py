"""`learned`: a temporal convolution net lifts a view's 2D keypoints to 3D (ONNX, on the CPU).

The net (after VideoPose3D's dilated temporal convolutions) sees `receptive` frames (2.7 s at
30 Hz) of the 13 upper-body keypoints around each frame, normalised by features.features, and
gives the 13 joints relative to the neck in the camera's axes: the depth sign of each bone comes
from how the 2D moves over time, as learned from motion capture seen by random cameras
(lift.training.lifter_net, benchmarks/train_lifter.py). The packaged model was trained on
bvhtools' test.bvh outside 31–51 s only (its sidecar JSON names the data and the command).

The view is resampled to 30 Hz for the net and back to its own timestamps; the ends are padded
with the first and last frame. Output: Pose3D in the camera frame (x right, y down, z forward),
metres as far as `geometric.shoulder_width_m` (a neck → mid-hip length of
features.SHOULDERS_PER_SPINE times it); knees and
ankles NaN; frames without both shoulders and both hips NaN. Confidence: the 2D keypoint's.

With `mirror_average` the 2D is also lifted flipped left-right (ray x → −x, sides exchanged) and
the mirrored-back result averaged with the direct one, so the lift is symmetric by construction.

Measured (benchmarks/fidelity.py, the packaged model: 8,000 steps, 18 min on two cores): from
BlazePose on the renders of test.bvh 31–41 s at 0/30/60°, Pepper hand error 5.0/4.5/4.5 cm and
2/3/6 % wrong depth signs (`blazepose-world` 11.9/10.3/8.3 cm, 16–26 %); from true 2D of test.bvh
31–51 s 1.9–3.0 cm; on held-out motion (test2/test3) 5.3–7.0 cm from true 2D. It is the default.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gesturebank.config import Config, FittedConfig, GeometricConfig, LearnedConfig
from gesturebank.errors import InputError
from gesturebank.lift import LifterTraits, TakeViews
from gesturebank.lift.depth_confidence import LEARNED
from gesturebank.lift.fitted import pinhole
from gesturebank.lift.learned import features as F
from gesturebank.lift.scoring import MIRROR
from gesturebank.poses import Pose3D
from gesturebank.skeletons import COCO17

if TYPE_CHECKING:
    import onnxruntime as ort

_MIRROR13 = MIRROR[: F.N_JOINTS]  # each joint's mirror image (left ↔ right)
PACKAGED = Path(__file__).resolve().parents[2] / "data" / "learned-lifter.onnx"


def model_path(options: LearnedConfig) -> Path:
    """The ONNX file of `options` (the packaged one for an empty `onnx_file`)."""
    return Path(options.onnx_file) if options.onnx_file else PACKAGED


@cache
def _session(path: str, threads: int) -> tuple[ort.InferenceSession, dict[str, Any]]:
    import onnxruntime as ort

    sidecar = Path(path).with_suffix(".json")
    try:
        meta = json.loads(sidecar.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise InputError(f"{sidecar}: the learned lifter's sidecar is unreadable ({err})") from None
    if meta.get("features") != F.N_FEATURES or meta.get("outputs") != F.N_OUTPUTS:
        raise InputError(f"{sidecar}: made for other features than this gesturebank's")
    options = ort.SessionOptions()
    options.intra_op_num_threads = threads
    options.inter_op_num_threads = 1
    try:
        session = ort.InferenceSession(path, options, providers=["CPUExecutionProvider"])
    except Exception as err:  # onnxruntime raises its own types for missing and bad files
        raise InputError(f"{path}: not a loadable ONNX model ({err})") from None
    return session, meta


class LearnedLifter:
    name = "learned"
    traits = LifterTraits(depth_calibration=LEARNED)

    def __init__(
        self,
        *,
        learned: LearnedConfig | None = None,
        fitted: FittedConfig | None = None,
        geometric: GeometricConfig | None = None,
    ) -> None:
        """learned: the lifter's section; fitted: its camera (`fov_deg`) without calibration;
        geometric: `shoulder_width_m`, the scale (None: their defaults)."""
        self.options = learned or LearnedConfig()
        self.fitted = fitted or FittedConfig()
        self.geometric = geometric or GeometricConfig()

    @classmethod
    def from_config(cls, config: Config) -> LearnedLifter:
        """The registry's factory (gesturebank.lift): `learned`, `fitted`, `geometric`."""
        return cls(
            learned=config.lifter.learned,
            fitted=config.lifter.fitted,
            geometric=config.lifter.geometric,
        )

    def lift(self, views: TakeViews) -> Pose3D:
        """One view of any skeleton → Pose3D (T, 17, 3), camera frame (module docstring)."""
        pose2d = views.single(self.name)
        coco = pose2d.to_coco17()
        kp = coco.keypoints[:, : F.N_JOINTS].astype(np.float64)
        camera = views.single_camera(self.name)
        focal, center, pixels = pinhole(kp[..., :2], coco.image_size, camera=camera,
                                        fov_deg=self.fitted.fov_deg)  # fmt: skip
        uv = (pixels - center) / focal
        ok = F.torso_ok(uv)
        joints = np.full((len(kp), len(COCO17), 3), np.nan)
        if ok.sum() >= 2:
            joints[:, : F.N_JOINTS] = self._lift_uv(uv, coco.timestamps, ok)
        joints[~ok] = np.nan
        missing = ~np.isfinite(joints).all(-1)
        confidence = np.where(missing, np.nan, coco.keypoints[..., 2])
        return Pose3D(
            joints.astype(np.float32),
            confidence.astype(np.float32),
            coco.timestamps,
            frame="camera",
            units="m",
            meta={"lifter": self.name, "model": model_path(self.options).name},
        )

    def _lift_uv(self, uv: np.ndarray, times: np.ndarray, ok: np.ndarray) -> np.ndarray:
        """(T, 13, 3) camera-frame joints of ray coordinates uv (T, 13, 2) at `times`."""
        session, meta = _session(str(model_path(self.options)), self.options.threads)
        times = np.asarray(times, np.float64)
        seen = np.flatnonzero(ok)
        grid = np.arange(times[seen[0]], times[seen[-1]] + 0.5 / F.RATE_HZ, 1 / F.RATE_HZ)
        filled = F.fill_gaps(np.where(ok[:, None, None], uv, np.nan))
        resampled = F.resample(filled[seen], times[seen], at=grid)
        half = (int(meta["architecture"]["receptive"]) - 1) // 2

        def net(rays: np.ndarray) -> np.ndarray:
            x, neck, scale = F.features(rays)
            padded = np.pad(x, ((half, half), (0, 0)), mode="edge")
            out = session.run(["joints"], {"keypoints": padded.T[None]})[0][0].T
            return F.camera_joints(out, neck, scale=scale,
                                   shoulder_width_m=self.geometric.shoulder_width_m)  # fmt: skip

        joints = net(resampled)
        if self.options.mirror_average:  # the mirror image (ray x → −x, sides exchanged), back
            flip = np.array([-1.0, 1.0, 1.0])
            mirrored = net(resampled[:, _MIRROR13] * flip[:2])[:, _MIRROR13] * flip
            joints = (joints + mirrored) / 2
        return F.resample(joints, grid, at=times)
