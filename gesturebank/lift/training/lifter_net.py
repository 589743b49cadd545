"""Training of the `learned` lifter (gesturebank.lift.learned): a dilated temporal convolution
net (after VideoPose3D, Pavllo et al. CVPR 2019) from 2D keypoint windows to root-relative 3D.

Training pairs are made on the fly (issue 39: a net that learns geometry, not one take): most
stretches are gesture motion made up over the upper body's range with random proportions
(lifter_motion), the rest stretches of motion capture, played faster or slower, optionally
mirrored, given other proportions or a sampled arm motion (lifter_poses). Each is seen by a
random camera as people film (lifter_views: height, distance, field of view, aim, roll, lens,
the focal known or assumed; kornia's batched geometry) with BlazePose-like 2D error (drift, bias,
blur, left/right swaps, dropped keypoints), then turned into the network's input by the very
function the lifter uses (features.features). Batches are made in a worker process beside the
training. The loss is the mean joint distance in units of the neck → mid-hip length, arms
weighted up.
"""

from __future__ import annotations

import json
import multiprocessing
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from gesturebank.lift.learned import features as F
from gesturebank.lift.scoring import MIRROR
from gesturebank.lift.training.lifter_motion import gesture_take
from gesturebank.lift.training.lifter_poses import Ranges, reproportion, sample_arm
from gesturebank.lift.training.lifter_views import CameraRanges, detector_noise, view_batch
from gesturebank.mocap.pose import body_axes

SNAPSHOT_STEPS = 1000
LOOKAHEAD = 4  # batches made ahead of the training step
ARM_WEIGHT = 2.0  # loss weight of elbows and wrists
# loss weight of the mid-hip's distance (the torso's tilt towards the camera; issue 39's floors:
# the tilt is most of the gap on real footage), added to the joints' weighted mean
TILT_WEIGHT = 0.5
UP = np.array([0.0, 0.0, 1.0])  # lifter_motion's world up
_ARMS = [F.JOINTS.index(j) for j in F.JOINTS if "elbow" in j or "wrist" in j]
_HIPS = [F.JOINTS.index(j) for j in ("left_hip", "right_hip")]


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
class Sampler:
    """Training stretches: `gesture_share` of them made up (lifter_motion), the rest from motion
    capture `takes` (joints (T, 17, 3) m, any y/z-up world, at RATE_HZ), each seen by a random
    camera with detector-like 2D error (lifter_views)."""

    takes: list[np.ndarray]
    frames: int  # input frames per sample
    cameras: CameraRanges = field(default_factory=CameraRanges)
    gesture_share: float = 0.6  # stretches made up by lifter_motion
    clean_share: float = 0.2  # samples without detector noise
    reproportion_share: float = 0.5  # mocap stretches given other proportions (lifter_poses)
    sampled_arm_share: float = 0.3  # mocap arms given a sampled motion, each (lifter_poses)
    ranges: Ranges = field(default_factory=Ranges)
    speed: tuple[float, float] = (0.7, 1.6)  # playback speed factors of the mocap

    def batch(self, rng: np.random.Generator, size: int) -> tuple[np.ndarray, np.ndarray]:
        """(size, N_FEATURES, frames) input and (size, N_OUTPUTS, frames) targets (the
        trimmed ends are the caller's)."""
        xs: list[np.ndarray] = []
        ys: list[np.ndarray] = []
        while len(xs) < size:  # a stretch no camera saw is replaced by another
            stretches, ups = zip(*(self.stretch(rng) for _ in range(size - len(xs))), strict=True)
            uv, local, outside, seen = view_batch(
                list(stretches), list(ups), rng=rng, cams=self.cameras
            )
            for k in np.flatnonzero(seen):
                made = uv[k]
                if rng.random() >= self.clean_share:
                    made = detector_noise(made, local[k], outside=outside[k], rng=rng)
                x = F.features(F.fill_gaps(made))[0].T
                neck = local[k][:, [5, 6]].mean(1)
                spine = np.median(np.linalg.norm(neck - local[k][:, [11, 12]].mean(1), axis=-1))
                y = ((local[k] - neck[:, None]) / spine).reshape(self.frames, -1).T
                if np.isfinite(x).all() and np.isfinite(y).all():
                    xs.append(x)
                    ys.append(y)
        return np.stack(xs).astype(np.float32), np.stack(ys).astype(np.float32)

    def stretch(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray | None]:
        """(frames, 17, 3) world joints and the world's up (None: the torso's): made up, or a
        mocap stretch played faster or slower, maybe mirrored, given other proportions or
        sampled arm motion (lifter_poses)."""
        if not self.takes or rng.random() < self.gesture_share:
            return gesture_take(rng, self.frames), UP
        lengths = np.array([len(t) for t in self.takes], float)
        speed = rng.uniform(*self.speed)
        need = int(np.ceil(self.frames * speed)) + 1
        usable = np.maximum(lengths - need, 0)
        take = self.takes[rng.choice(len(self.takes), p=usable / usable.sum())]
        start = rng.uniform(0, len(take) - need)
        at = start + np.arange(self.frames) * speed
        joints = F.resample(take, np.arange(len(take), dtype=float), at=at)
        if rng.random() < 0.5:  # mirrored across the person's sagittal plane, sides exchanged
            left = body_axes(joints)[1]
            joints = joints - 2 * (joints @ left)[..., None] * left
            joints = joints[:, MIRROR]
        if rng.random() < self.reproportion_share:
            joints = reproportion(joints, rng=rng, ranges=self.ranges)
        for side in ("left", "right"):
            if rng.random() < self.sampled_arm_share:
                joints = sample_arm(joints, side, rng=rng, ranges=self.ranges)
        return joints, None


def loss_fn(pred: torch.Tensor, target: torch.Tensor, *, tilt_weight: float = TILT_WEIGHT
            ) -> torch.Tensor:  # fmt: skip
    """Weighted mean joint distance of (B, N_OUTPUTS, T) predictions, plus `tilt_weight` times
    the mid-hip's distance (the torso's tilt; the neck is the origin)."""
    b, _, t = pred.shape
    diff = (pred - target).reshape(b, F.N_JOINTS, 3, t)
    d = diff.norm(dim=2)
    w = torch.ones(F.N_JOINTS)
    w[_ARMS] = ARM_WEIGHT
    tilt = diff[:, _HIPS].mean(1).norm(dim=1).mean()
    return (d * w[None, :, None]).sum(1).mean() / w.sum() + tilt_weight * tilt


@dataclass(frozen=True)
class Schedule:
    steps: int = 4000
    batch: int = 16
    outputs: int = 96  # output frames per sample (inputs: outputs + receptive − 1)
    lr_start: float = 1e-3
    lr_end: float = 1e-5
    rng_seed: int = 0
    torch_threads: int = 1  # two threads on two busy cores ran 8× slower than one
    workers: int = 1  # processes making the batches beside the training (0: in line)


_WORKER: dict[str, Sampler] = {}


def _start_worker(sampler: Sampler) -> None:
    torch.set_num_threads(1)
    _WORKER["sampler"] = sampler


def _worker_batch(seed: int, step: int, size: int) -> tuple[np.ndarray, np.ndarray]:
    return _WORKER["sampler"].batch(np.random.default_rng([seed, step]), size)


def _batches(sampler: Sampler, schedule: Schedule) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Step 1…steps's training batches, each from its own seed, made `schedule.workers`
    processes ahead of the training (the data costs as much as the network's step)."""
    if schedule.workers == 0:
        for step in range(1, schedule.steps + 1):
            yield sampler.batch(np.random.default_rng([schedule.rng_seed, step]), schedule.batch)
        return
    ctx = multiprocessing.get_context("spawn")  # no forked torch thread pools
    with ctx.Pool(schedule.workers, initializer=_start_worker, initargs=(sampler,)) as pool:
        ahead: deque[Any] = deque()
        for step in range(1, schedule.steps + 1 + LOOKAHEAD):
            if step <= schedule.steps:
                args = (schedule.rng_seed, step, schedule.batch)
                ahead.append(pool.apply_async(_worker_batch, args))
            if step > LOOKAHEAD:
                yield ahead.popleft().get()


def from_onnx(path: Path, arch: Architecture) -> TemporalLifterNet:
    """A net with the weights of one exported by `export` (which folds each batch norm into the
    convolution before it): the convolutions take the folded weights, each norm is made the
    identity plus the folded bias, so the net in eval mode computes what the file does."""
    import onnx
    from onnx import numpy_helper

    graph = onnx.load(str(path)).graph
    values = {t.name: numpy_helper.to_array(t) for t in graph.initializer}
    folded = [[values[name] for name in node.input[1:]] for node in graph.node
              if node.op_type == "Conv"]  # fmt: skip
    net = TemporalLifterNet(arch)
    convs = [m for m in net.modules() if isinstance(m, nn.Conv1d)]
    norms = [m for m in net.modules() if isinstance(m, nn.BatchNorm1d)] + [None]
    if len(folded) != len(convs):
        raise ValueError(f"{path}: {len(folded)} convolutions, the architecture has {len(convs)}")
    with torch.no_grad():
        for conv, norm, (weight, bias) in zip(convs, norms, folded, strict=True):
            if tuple(weight.shape) != tuple(conv.weight.shape):
                raise ValueError(f"{path}: a convolution of shape {weight.shape}, the "
                                 f"architecture's is {tuple(conv.weight.shape)}")  # fmt: skip
            conv.weight.copy_(torch.from_numpy(weight.copy()))
            target = conv.bias if norm is None else norm.bias
            assert target is not None
            target.copy_(torch.from_numpy(bias.copy()))
            if norm is not None:
                norm.weight.fill_(1.0)
                norm.running_mean.zero_()  # type: ignore[union-attr]
                norm.running_var.fill_(1.0 - norm.eps)  # type: ignore[union-attr]
    net.eval()
    return net


def _training_mode(net: TemporalLifterNet, *, frozen_norms: bool) -> None:
    """`net` in training mode; its batch norms keep their statistics if `frozen_norms` (a
    fine-tuned net then starts from the very function it was given, not from the statistics of
    small batches)."""
    net.train()
    if frozen_norms:
        for norm in net.modules():
            if isinstance(norm, nn.BatchNorm1d):
                norm.eval()


def train(
    sampler_for: Callable[[int], Sampler],
    *,
    arch: Architecture,
    schedule: Schedule,
    log: Callable[[int, float, float], None] | None = None,
    snapshot: Callable[[int, TemporalLifterNet], None] | None = None,
    start_from: Path | None = None,
) -> TemporalLifterNet:
    """Adam with a cosine decay; `sampler_for(input_frames)` makes the data; `log(step, loss,
    seconds)` is called every 100 steps, `snapshot(step, net)` (the net in eval mode) every
    SNAPSHOT_STEPS. `start_from`: an exported net (ONNX) to fine-tune instead of a new one."""
    torch.manual_seed(schedule.rng_seed)
    torch.set_num_threads(schedule.torch_threads)
    sampler = sampler_for(schedule.outputs + arch.receptive - 1)
    net = TemporalLifterNet(arch) if start_from is None else from_onnx(start_from, arch)
    frozen = start_from is not None
    opt = torch.optim.Adam(net.parameters(), lr=schedule.lr_start)
    ratio = schedule.lr_end / schedule.lr_start
    sched = torch.optim.lr_scheduler.LambdaLR(
        opt, lambda s: ratio + (1 - ratio) * 0.5 * (1 + np.cos(np.pi * s / schedule.steps))
    )
    half = (arch.receptive - 1) // 2
    start, running = time.perf_counter(), 0.0
    _training_mode(net, frozen_norms=frozen)
    for step, (x, y) in enumerate(_batches(sampler, schedule), start=1):
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
        if snapshot is not None and step % SNAPSHOT_STEPS == 0 and step < schedule.steps:
            net.eval()
            snapshot(step, net)
            _training_mode(net, frozen_norms=frozen)
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
