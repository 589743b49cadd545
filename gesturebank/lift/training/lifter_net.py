"""Training of the `learned` lifter (gesturebank.lift.learned): a dilated temporal convolution
net (after VideoPose3D, Pavllo et al. CVPR 2019) from 2D keypoint windows to root-relative 3D.

Training pairs are made on the fly from motion capture: each sample is a stretch of the take,
played faster or slower, optionally mirrored, given other proportions or a sampled arm motion
(lifter_poses), seen by a random pinhole camera (azimuth around the person's mean front over the
stretch, height, distance, field of view, aim) that keeps the person in its picture, its joints
projected and disturbed by detector-like 2D noise (`NOISE_BIAS_Y`, `NOISE_SD`), then turned into the
network's input by the very function the lifter uses (features.features). The loss is the
mean joint distance in units of the neck → mid-hip length, arms weighted up.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch
from scipy.ndimage import gaussian_filter1d
from torch import nn

from gesturebank.geometry import Camera
from gesturebank.lift.learned import features as F
from gesturebank.lift.scoring import MIRROR, look_at
from gesturebank.lift.training.lifter_poses import Ranges, reproportion, sample_arm
from gesturebank.mocap.pose import body_axes

# BlazePose's 2D error against the projected truth on the project's renders of test.bvh 21–31 s
# (a tuning stretch) at 0/30/60°, in neck → mid-hip lengths, per joint (nose … right_hip): the
# mean offset along the image's y (down; the shoulders sit high) and the standard deviation about
# it (x and y averaged). The error drifts slowly (lag-1 autocorrelation 0.98 at 30 fps).
NOISE_BIAS_Y = (-0.010, -0.004, -0.027, 0.047, -0.011, -0.073, -0.037, -0.041, 0.029, -0.005,
                0.016, 0.041, 0.032)  # fmt: skip
NOISE_SD = (0.048, 0.040, 0.050, 0.038, 0.034, 0.057, 0.059, 0.060, 0.083, 0.040, 0.063, 0.042,
            0.038)  # fmt: skip
NOISE_SMOOTH_FRAMES = 4.0  # σ of the Gaussian that makes the white noise drift
MIN_DEPTH_M = 0.5  # nearer than this to a camera, a person is not seen whole
ARM_WEIGHT = 2.0  # loss weight of elbows and wrists
_ARMS = [F.JOINTS.index(j) for j in F.JOINTS if "elbow" in j or "wrist" in j]
_MIRROR13 = MIRROR[: F.N_JOINTS]


@dataclass(frozen=True)
class Architecture:
    """The network's shape (written into the ONNX file's sidecar and checked against it)."""

    channels: int = 128
    dilations: tuple[int, ...] = (3, 9, 27)
    kernel: int = 3
    dropout_p: float = 0.1

    @property
    def receptive(self) -> int:
        """Input frames per output frame."""
        return 1 + (self.kernel - 1) * (1 + sum(self.dilations))


class TemporalLifterNet(nn.Module):
    """(B, N_FEATURES, T + receptive − 1) → (B, N_OUTPUTS, T): a kernel-wide convolution, then
    residual blocks of a dilated convolution and a 1×1 one, each trimmed to the valid frames."""

    def __init__(self, arch: Architecture) -> None:
        super().__init__()
        c, k = arch.channels, arch.kernel
        self.arch = arch
        self.stem = nn.Sequential(nn.Conv1d(F.N_FEATURES, c, k, bias=False), nn.BatchNorm1d(c),
                                  nn.ReLU(), nn.Dropout(arch.dropout_p))  # fmt: skip
        self.blocks = nn.ModuleList(self._block(c, k, d, arch.dropout_p) for d in arch.dilations)
        self.trims = [(k - 1) * d // 2 for d in arch.dilations]
        self.head = nn.Conv1d(c, F.N_OUTPUTS, 1)

    @staticmethod
    def _block(c: int, k: int, dilation: int, dropout: float) -> nn.Sequential:
        """A dilated convolution over time, then a 1×1 one, each normalised and rectified."""
        return nn.Sequential(nn.Conv1d(c, c, k, dilation=dilation, bias=False),
                             nn.BatchNorm1d(c), nn.ReLU(), nn.Dropout(dropout),
                             nn.Conv1d(c, c, 1, bias=False), nn.BatchNorm1d(c), nn.ReLU(),
                             nn.Dropout(dropout))  # fmt: skip

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = self.stem(x)
        for block, trim in zip(self.blocks, self.trims, strict=True):
            x = x[:, :, trim:-trim] + block(x)
        return self.head(x)


@dataclass(frozen=True)
class Cameras:
    """Ranges of the random training cameras."""

    front_share: float = 0.75  # the rest anywhere around the person
    front_deg: float = 90.0  # azimuth ± this many degrees from the person's front
    height_range_m: tuple[float, float] = (-0.3, 1.0)  # above the chest
    distance_range_m: tuple[float, float] = (2.0, 5.0)
    fov_range_deg: tuple[float, float] = (35.0, 75.0)
    aim_sd_m: float = 0.15  # the camera aims this far off the chest


@dataclass(frozen=True)
class Sampler:
    """Training stretches from motion capture: `takes` are (joints (T, 17, 3) m, any y/z-up
    world, at RATE_HZ) arrays the stretches lie within."""

    takes: list[np.ndarray]
    frames: int  # input frames per sample
    cameras: Cameras = field(default_factory=Cameras)
    clean_share: float = 0.15  # samples without detector noise
    camera_tries: int = 10  # cameras tried for a stretch before another stretch is drawn
    reproportion_share: float = 0.5  # stretches given other proportions (lifter_poses)
    sampled_arm_share: float = 0.3  # arms given a sampled motion, each (lifter_poses)
    ranges: Ranges = field(default_factory=Ranges)
    speed: tuple[float, float] = (0.8, 1.25)  # playback speed factors

    def batch(self, rng: np.random.Generator, size: int) -> tuple[np.ndarray, np.ndarray]:
        """(size, N_FEATURES, frames) input and (size, N_OUTPUTS, frames − receptive + 1)
        targets are made by `sample`; the trimmed ends are the caller's."""
        xs, ys = zip(*(self.sample(rng) for _ in range(size)), strict=True)
        return np.stack(xs), np.stack(ys)

    def sample(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """One stretch: input (N_FEATURES, frames), target (N_OUTPUTS, frames) float32."""
        while True:
            made = self._try(rng)
            if made is not None:
                return made

    def _try(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray] | None:
        """A random stretch seen by a random camera; None if the person leaves every camera's
        picture tried (in_picture)."""
        lengths = np.array([len(t) for t in self.takes], float)
        speed = rng.uniform(*self.speed)
        need = int(np.ceil(self.frames * speed)) + 1
        usable = np.maximum(lengths - need, 0)
        take = self.takes[rng.choice(len(self.takes), p=usable / usable.sum())]
        start = rng.uniform(0, len(take) - need)
        at = start + np.arange(self.frames) * speed
        idx = np.arange(len(take), dtype=float)
        joints = F.resample(take, idx, at)
        if rng.random() < 0.5:  # mirrored across the person's sagittal plane, sides exchanged
            left = body_axes(joints)[1]
            joints = joints - 2 * (joints @ left)[..., None] * left
            joints = joints[:, MIRROR]
        if rng.random() < self.reproportion_share:
            joints = reproportion(joints, rng=rng, ranges=self.ranges)
        for side in ("left", "right"):
            if rng.random() < self.sampled_arm_share:
                joints = sample_arm(joints, side, rng=rng, ranges=self.ranges)
        for _ in range(self.camera_tries):
            cam = self._camera(rng, joints)
            local = cam.to_camera(joints)[:, : F.N_JOINTS]
            uv = local[..., :2] / local[..., 2:3]
            if in_picture(local, cam):
                break
        else:
            return None
        spine_px = np.linalg.norm(
            uv[:, [5, 6]].mean(1) - uv[:, [11, 12]].mean(1), axis=-1
        )  # the truth's neck → mid-hip in ray units, per frame
        if rng.random() >= self.clean_share:
            uv = uv + spine_px[:, None, None] * self._noise(rng)
        x = F.features(F.fill_gaps(uv))[0]
        neck = local[:, [5, 6]].mean(1)
        spine = np.median(np.linalg.norm(neck - local[:, [11, 12]].mean(1), axis=-1))
        y = (local - neck[:, None]) / spine
        return x.T, y.reshape(self.frames, -1).T.astype(np.float32)

    def _camera(self, rng: np.random.Generator, joints: np.ndarray) -> Camera:
        cams = self.cameras
        front, left, up = body_axes(joints)
        neck = joints[:, [5, 6]].mean(1)
        hips = joints[:, [11, 12]].mean(1)
        chest = (0.75 * neck + 0.25 * hips).mean(0)
        scale = float(np.median(np.linalg.norm(neck - hips, axis=1))) / 0.5
        if rng.random() < cams.front_share:
            azimuth = np.deg2rad(rng.uniform(-cams.front_deg, cams.front_deg))
        else:
            azimuth = rng.uniform(-np.pi, np.pi)
        eye = chest + scale * (
            rng.uniform(*cams.distance_range_m) * (np.cos(azimuth) * front + np.sin(azimuth) * left)
            + rng.uniform(*cams.height_range_m) * up
        )
        target = chest + scale * rng.normal(0.0, cams.aim_sd_m, 3)
        return look_at(eye=eye, target=target, up=up, size=(1280, 720),
                       fov_deg=rng.uniform(*cams.fov_range_deg))  # fmt: skip

    def _noise(self, rng: np.random.Generator) -> np.ndarray:
        """(frames, 13, 2) detector-like error in neck → mid-hip lengths."""
        shape = (self.frames, F.N_JOINTS, 2)
        drift = gaussian_filter1d(rng.normal(size=shape), NOISE_SMOOTH_FRAMES, axis=0)
        drift /= drift.std(axis=0, keepdims=True) + 1e-9
        level = rng.uniform(0.5, 1.5)
        noise = drift * np.asarray(NOISE_SD)[None, :, None] * level
        noise += rng.normal(0.0, 0.01, shape)
        bias = np.stack([rng.normal(0.0, 0.03, F.N_JOINTS),
                         np.asarray(NOISE_BIAS_Y) * rng.uniform(0.0, 1.5)], -1)  # fmt: skip
        return noise + bias[None]


def in_picture(local: np.ndarray, cam: Camera, *, margin: float = 0.1) -> bool:
    """Whether camera-frame joints (T, J, 3) stay in front of the camera and inside its image
    (widened by `margin` of its size) in every frame, as a person a detector finds does. The
    mocap's person walks about: a camera placed for a stretch's mean may see them leave the
    picture or come within centimetres, where the network's inputs explode (the neck's ray
    coordinates reached 700; rel. keypoints 4,000 torso sizes)."""
    if not (local[..., 2] > MIN_DEPTH_M).all():
        return False
    px = cam.distort(local[..., :2] / local[..., 2:3])
    size = np.asarray(cam.size, float)
    return bool(((px > -margin * size) & (px < (1 + margin) * size)).all())


def loss_fn(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Weighted mean joint distance of (B, N_OUTPUTS, T) predictions."""
    b, _, t = pred.shape
    d = (pred - target).reshape(b, F.N_JOINTS, 3, t).norm(dim=2)
    w = torch.ones(F.N_JOINTS)
    w[_ARMS] = ARM_WEIGHT
    return (d * w[None, :, None]).sum(1).mean() / w.sum()


@dataclass(frozen=True)
class Schedule:
    steps: int = 8000
    batch: int = 16
    outputs: int = 96  # output frames per sample (inputs: outputs + receptive − 1)
    lr_start: float = 1e-3
    lr_end: float = 1e-5
    rng_seed: int = 0
    torch_threads: int = 2


def train(
    sampler_for: Callable[[int], Sampler],
    *,
    arch: Architecture,
    schedule: Schedule,
    log: Callable[[int, float, float], None] | None = None,
) -> TemporalLifterNet:
    """Adam with a cosine decay; `sampler_for(input_frames)` makes the data; `log(step, loss,
    seconds)` is called every 100 steps."""
    torch.manual_seed(schedule.rng_seed)
    torch.set_num_threads(schedule.torch_threads)
    rng = np.random.default_rng(schedule.rng_seed)
    sampler = sampler_for(schedule.outputs + arch.receptive - 1)
    net = TemporalLifterNet(arch)
    opt = torch.optim.Adam(net.parameters(), lr=schedule.lr_start)
    ratio = schedule.lr_end / schedule.lr_start
    sched = torch.optim.lr_scheduler.LambdaLR(
        opt, lambda s: ratio + (1 - ratio) * 0.5 * (1 + np.cos(np.pi * s / schedule.steps))
    )
    half = (arch.receptive - 1) // 2
    start, running = time.perf_counter(), 0.0
    net.train()
    for step in range(1, schedule.steps + 1):
        x, y = sampler.batch(rng, schedule.batch)
        pred = net(torch.from_numpy(x))
        loss = loss_fn(pred, torch.from_numpy(y[:, :, half : half + pred.shape[2]]))
        opt.zero_grad()
        loss.backward()
        opt.step()
        sched.step()
        value = float(loss.detach())
        running = 0.98 * running + 0.02 * value if step > 1 else value
        if log is not None and (step % 100 == 0 or step == schedule.steps):
            log(step, running, time.perf_counter() - start)
    net.eval()
    return net


def export(net: TemporalLifterNet, path: Path, *, sidecar: dict[str, object]) -> None:
    """The net as ONNX at `path` (input `keypoints` (1, N_FEATURES, T), output `joints`
    (1, N_OUTPUTS, T − receptive + 1), T dynamic) and its sidecar JSON beside it."""
    arch = net.arch
    dummy = torch.zeros(1, F.N_FEATURES, arch.receptive + 20)
    torch.onnx.export(
        net, (dummy,), str(path), input_names=["keypoints"], output_names=["joints"],
        dynamic_axes={"keypoints": {2: "frames"}, "joints": {2: "frames_out"}},
        opset_version=17, dynamo=False,
    )  # fmt: skip
    meta = {
        "architecture": {**asdict(arch), "receptive": arch.receptive},
        "features": F.N_FEATURES,
        "outputs": F.N_OUTPUTS,
        "joints": list(F.JOINTS),
        "rate_hz": F.RATE_HZ,
        **sidecar,
    }
    path.with_suffix(".json").write_text(json.dumps(meta, indent=2) + "\n", encoding="utf-8")
