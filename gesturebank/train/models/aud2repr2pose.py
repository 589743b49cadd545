"""Aud2Repr2Pose (seed 001, Kucherenko et al.): speech → a learned motion representation → pose.

Three steps, trained in two stages (`stages`):
1. MotionED, a denoising autoencoder over motion frames m = [g_t, Δg_t] (11 angles in [0, 1]
   and their velocities): Gaussian noise of 0.05 × each dimension's training std is added to
   the input, the clean frame is the target. One hidden layer each way, the code z between.
2. SpeechE, the Aud2Pose network (FC → BiGRU over ±C frames, `[train.aud2pose]` sizes and
   schedule), trained by MSE to MotionE's code of the true motion (MotionE frozen).
3. Synthesis chains SpeechE → MotionD; its first 11 outputs, clamped to [0, 1], are the angles.
Validation: the DAE's reconstruction in stage 1, the chained angles' loss L in stage 2.
Non-causal (SpeechE sees C future frames).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np
import torch
from torch import nn

from gesturebank.config import TrainConfig
from gesturebank.datasets.torch import Segment, masked_mse
from gesturebank.errors import InputError
from gesturebank.train.models.layers import FCStack, centre, windows
from gesturebank.train.schedule import Schedule, adam_schedule
from gesturebank.train.torch_runtime import validation_loss

N_ANGLES = 11
N_MOTION = 2 * N_ANGLES  # angles and velocities


def motion_frames(target: torch.Tensor, mask: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Angles `(B, T, 11)` → m = [g_t, g_t − g_{t−1}] `(B, T−1, 22)` and whether each frame and
    its predecessor are fully known `(B, T−1)`."""
    m = torch.cat([target[:, 1:], target[:, 1:] - target[:, :-1]], dim=-1)
    known = mask[:, 1:].all(dim=-1) & mask[:, :-1].all(dim=-1)
    return m, known


def dae_noise_std(motion: np.ndarray, scale: float) -> np.ndarray:
    """The DAE's input noise std per dimension: `scale` × the std of `motion (N, 22)`."""
    return (scale * np.asarray(motion, np.float64).std(axis=0)).astype(np.float32)


class SpeechEncoder(nn.Module):
    """The Aud2Pose network with `n_out` linear outputs: `(B, T, F)` → `(B, T, n_out)`."""

    def __init__(
        self, n_features: int, fc_layers: int, units: int, dropout: float, context: int,
        n_out: int,
    ) -> None:  # fmt: skip
        super().__init__()
        self.context = context
        self.fc = FCStack(n_features, fc_layers, units, dropout)
        self.gru = nn.GRU(units, units, batch_first=True, bidirectional=True)
        self.drop = nn.Dropout(dropout)
        self.out = nn.Linear(2 * units, n_out)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        b, t, _ = x.shape
        y, _ = self.gru(windows(self.fc(x), self.context))
        return self.out(self.drop(centre(y))).reshape(b, t, -1)


class Aud2Repr2Pose(nn.Module):
    """`(B, T, F)` → `(B, T, 11)` in [0, 1] through the motion code."""

    kind = "aud2repr2pose"
    causal = False
    # SpeechE is Aud2Pose: its sizes are [train.aud2pose]'s, the code's [train.aud2repr2pose]'s
    config_sections = ("aud2pose", "aud2repr2pose")
    noise_std: torch.Tensor  # buffer (22,): the DAE's input noise, set by `stages`

    def __init__(
        self, n_features: int, fc_layers: int, units: int, dropout: float, context: int,
        code: int, noise: float,
    ) -> None:  # fmt: skip
        super().__init__()
        self.n_features, self.fc_layers, self.units = n_features, fc_layers, units
        self.dropout, self.context, self.code, self.noise = dropout, context, code, noise
        self.motion_encoder = nn.Sequential(nn.Linear(N_MOTION, code), nn.Tanh())
        self.motion_decoder = nn.Linear(code, N_MOTION)
        self.speech_encoder = SpeechEncoder(n_features, fc_layers, units, dropout, context, code)
        self.register_buffer("noise_std", torch.zeros(N_MOTION))  # set from the training data
        self.stage = "speech"

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        m = self.motion_decoder(self.speech_encoder(x))
        return m[..., :N_ANGLES].clamp(0.0, 1.0)

    def corrupt(self, m: torch.Tensor) -> torch.Tensor:
        """The DAE's input: m plus N(0, noise_std²) per dimension."""
        return m + torch.randn_like(m) * self.noise_std

    def denoise(self, m: torch.Tensor) -> torch.Tensor:
        return self.motion_decoder(self.motion_encoder(m))

    # -- training in stages ------------------------------------------------------------------

    def stages(self, train_segments: Sequence[Segment]) -> Iterator[str]:
        motion = []
        for s in train_segments:
            t, mk = torch.from_numpy(s.target[None]), torch.from_numpy(s.mask[None])
            m, known = motion_frames(t, mk)
            motion.append(m[0][known[0]].numpy())
        frames = np.concatenate(motion)
        if len(frames) < 2:
            raise InputError("aud2repr2pose: fewer than 2 training frames with a fully known pose")
        self.noise_std.copy_(torch.from_numpy(dae_noise_std(frames, self.noise)))
        self.stage = "dae"
        yield "motion DAE"
        self.stage = "speech"
        yield "speech encoder"

    def stage_parameters(self) -> Iterator[nn.Parameter]:
        if self.stage == "dae":
            return iter([*self.motion_encoder.parameters(), *self.motion_decoder.parameters()])
        return self.speech_encoder.parameters()

    def schedule(self, config: TrainConfig) -> Schedule:
        if self.stage == "dae":  # frame pairs (for the velocity), fixed epochs as in [001]
            c = config.aud2repr2pose
            return Schedule("adam", c.dae_learning_rate, c.dae_batch_size, c.dae_epochs,
                            c.dae_epochs, 2, 1, None, c.dae_learning_rate)  # fmt: skip
        return adam_schedule(config.aud2pose, config)

    def loss(self, x: torch.Tensor, y: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        m, known = motion_frames(y, mask)
        k = known[..., None].expand_as(m)
        if self.stage == "dae":
            return masked_mse(self.denoise(self.corrupt(m)), m, mask=k)
        with torch.no_grad():
            code = self.motion_encoder(m)
        pred = self.speech_encoder(x)[:, 1:]
        return masked_mse(pred, code, mask=known[..., None].expand_as(code))

    @torch.no_grad()
    def validation_loss(self, segments: Sequence[Segment]) -> float:
        if self.stage != "dae":
            return validation_loss(self, segments)
        self.eval()
        err, count = 0.0, 0
        for s in segments:
            m, known = motion_frames(
                torch.from_numpy(s.target[None]), torch.from_numpy(s.mask[None])
            )
            clean = m[known]
            err += float(((self.denoise(clean) - clean) ** 2).sum())
            count += clean.numel()
        return err / max(count, 1)
