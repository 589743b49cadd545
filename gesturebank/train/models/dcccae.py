"""D-DCCCAE (seed 003, Lu et al.): speech and motion autoencoders tied by CCA, a regressor
between their codes, overlap-add, and an autoencoder post-filter. Three stages (`stages`):

1. Two autoencoders over ±C-frame segments (C = 3: 7 frames, flattened): each minimises its
   reconstruction error, and together they maximise the canonical correlation of their codes
   (`cca_correlation`, differentiable), weighted by `cca_weight`. [003] writes the CCA between
   an encoder's code and the other stream and leaves how it is computed open; here it is the
   DCCAE reading — between the two codes, all components, ridge `cca_reg`.
2. A feed-forward regressor, speech code → motion code, frame by frame, trained through the
   motion decoder (which is fine-tuned with it) to the true 7-frame motion segments.
3. The post-filter: an autoencoder over (2·post_context + 1)-frame windows of motion, trained
   to turn the overlap-added output of stages 1–2 into the true motion ("smooth the jerky
   output"). It is residual — window + AE(window), its last layer starting at zero — so it starts
   as the identity and training can only move it towards the truth.
Synthesis: speech segment at t → code → regressor → motion decoder → 7-frame segment; the
overlapping segments are averaged (overlap-add with equal weights), windows of that go through
the post-filter and are averaged again. Non-causal (C and post_context future frames).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Sequence

import torch
from torch import nn

from gesturebank.config import TrainConfig
from gesturebank.datasets.torch import Segment, masked_mse
from gesturebank.train.models.layers import span_mean, windows
from gesturebank.train.schedule import Schedule, adam_schedule
from gesturebank.train.torch_runtime import validation_loss

N_ANGLES = 11


def cca_correlation(a: torch.Tensor, b: torch.Tensor, *, reg: float) -> torch.Tensor:
    """Sum of the canonical correlations of `a (N, p)` and `b (N, q)` (differentiable): the
    singular values of Σaa^{-1/2} Σab Σbb^{-1/2}, with `reg`·I added to Σaa and Σbb."""
    a = a - a.mean(dim=0)
    b = b - b.mean(dim=0)
    n = a.shape[0] - 1

    def inv_sqrt(c: torch.Tensor) -> torch.Tensor:
        vals, vecs = torch.linalg.eigh(c)
        return vecs @ torch.diag(vals.clamp_min(1e-12).rsqrt()) @ vecs.T

    eye_a = torch.eye(a.shape[1], dtype=a.dtype)
    eye_b = torch.eye(b.shape[1], dtype=b.dtype)
    saa = a.T @ a / n + reg * eye_a
    sbb = b.T @ b / n + reg * eye_b
    t = inv_sqrt(saa) @ (a.T @ b / n) @ inv_sqrt(sbb)
    return torch.linalg.svdvals(t).sum()


def _mlp(sizes: list[int]) -> nn.Sequential:
    """Linear layers of `sizes`, ReLU between them (none after the last)."""
    layers: list[nn.Module] = []
    for i, (a, b) in enumerate(itertools.pairwise(sizes)):
        layers.append(nn.Linear(a, b))
        if i < len(sizes) - 2:
            layers.append(nn.ReLU())
    return nn.Sequential(*layers)


class DCCCAE(nn.Module):
    """`(B, T, F)` → `(B, T, 11)` in [0, 1]."""

    kind = "dcccae"
    causal = False
    config_sections = ("dcccae",)

    def __init__(
        self, n_features: int, context: int, ae_units: int, code: int, cca_weight: float,
        cca_reg: float, regressor_layers: int, regressor_units: int, post_context: int,
        post_code: int,
    ) -> None:  # fmt: skip
        super().__init__()
        self.n_features = n_features
        self.sizes = {
            "context": context, "ae_units": ae_units, "code": code, "cca_weight": cca_weight,
            "cca_reg": cca_reg, "regressor_layers": regressor_layers,
            "regressor_units": regressor_units, "post_context": post_context,
            "post_code": post_code,
        }  # fmt: skip
        c, h, z = int(context), int(ae_units), int(code)
        self.context, self.cca_weight, self.cca_reg = c, float(cca_weight), float(cca_reg)
        w = 2 * c + 1
        self.speech_encoder = _mlp([w * n_features, h, z])
        self.speech_decoder = _mlp([z, h, w * n_features])
        self.motion_encoder = _mlp([w * N_ANGLES, h, z])
        self.motion_decoder = _mlp([z, h, w * N_ANGLES])
        units = int(regressor_units)
        self.regressor = _mlp([z] + [units] * int(regressor_layers) + [z])
        self.post_context = int(post_context)
        pw = (2 * self.post_context + 1) * N_ANGLES
        self.post_filter = _mlp([pw, h, int(post_code), h, pw])
        last = self.post_filter[-1]
        assert isinstance(last, nn.Linear)
        nn.init.zeros_(last.weight)  # residual: the identity before training
        nn.init.zeros_(last.bias)
        self.stage = "done"

    # -- synthesis -------------------------------------------------------------------------------

    def segments(self, x: torch.Tensor) -> torch.Tensor:
        """`(B, T, D)` → the flattened ±C segment around every frame `(B·T, (2C+1)·D)`."""
        return windows(x, self.context).flatten(1)

    def motion_segments(self, x: torch.Tensor) -> torch.Tensor:
        """Speech `(B, T, F)` → the predicted motion segment per frame `(B, T, 2C+1, 11)`."""
        b, t, _ = x.shape
        code = self.regressor(self.speech_encoder(self.segments(x)))
        return self.motion_decoder(code).reshape(b, t, 2 * self.context + 1, N_ANGLES)

    def post(self, motion: torch.Tensor) -> torch.Tensor:
        b, t, _ = motion.shape
        w = 2 * self.post_context + 1
        win = windows(motion, self.post_context).flatten(1)
        out = win + self.post_filter(win)
        return span_mean(out.reshape(b, t, w, N_ANGLES)).clamp(0.0, 1.0)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        motion = span_mean(self.motion_segments(x)).clamp(0.0, 1.0)  # overlap-add
        return motion if self.stage in ("autoencoders", "regressor") else self.post(motion)

    # -- training in stages ------------------------------------------------------------------

    def stages(self, train_segments: Sequence[Segment]) -> Iterator[str]:
        for self.stage in ("autoencoders", "regressor", "post-filter"):
            yield self.stage
        self.stage = "done"

    def stage_parameters(self) -> Iterator[nn.Parameter]:
        parts = {
            "autoencoders": [self.speech_encoder, self.speech_decoder, self.motion_encoder,
                             self.motion_decoder],
            "regressor": [self.regressor, self.motion_decoder],  # the decoder is fine-tuned
            "post-filter": [self.post_filter],
        }[self.stage]  # fmt: skip
        return iter([p for part in parts for p in part.parameters()])

    def schedule(self, config: TrainConfig) -> Schedule:
        return adam_schedule(config.dcccae, config)

    def autoencoder_loss(self, x: torch.Tensor, y: torch.Tensor, m: torch.Tensor) -> torch.Tensor:
        """Stage 1 on the segments whose motion is fully known: both reconstructions − CCA."""
        known = windows(m.all(dim=-1, keepdim=True).float(), self.context).flatten(1).all(dim=1)
        xs, ys = self.segments(x)[known], self.segments(y)[known]
        if len(xs) < 2:
            return (self.speech_decoder(self.speech_encoder(self.segments(x))) * 0.0).sum()
        zs, zm = self.speech_encoder(xs), self.motion_encoder(ys)
        recon = ((self.speech_decoder(zs) - xs) ** 2).mean() + (
            (self.motion_decoder(zm) - ys) ** 2
        ).mean()
        return recon - self.cca_weight * cca_correlation(zs, zm, reg=self.cca_reg) / zs.shape[1]

    def loss(self, x: torch.Tensor, y: torch.Tensor, m: torch.Tensor) -> torch.Tensor:
        if self.stage == "autoencoders":
            return self.autoencoder_loss(x, y, m)
        if self.stage == "regressor":  # each predicted segment against the true one
            w = 2 * self.context + 1
            target = windows(y, self.context).reshape(*y.shape[:2], w, N_ANGLES)
            mask = windows(m.float(), self.context).reshape(*y.shape[:2], w, N_ANGLES) > 0
            return masked_mse(self.motion_segments(x), target, mask=mask)
        with torch.no_grad():  # post-filter: stages 1–2's output → the true motion
            rough = span_mean(self.motion_segments(x)).clamp(0.0, 1.0)
        return masked_mse(self.post(rough), y, mask=m)

    @torch.no_grad()
    def validation_loss(self, segments: Sequence[Segment]) -> float:
        if self.stage != "autoencoders":
            return validation_loss(self, segments)  # loss L of the angles, as every model
        self.eval()
        losses = []
        for s in segments:
            args = (torch.from_numpy(s.audio[None]), torch.from_numpy(s.target[None]),
                    torch.from_numpy(s.mask[None]))  # fmt: skip
            losses.append(float(self.autoencoder_loss(*args)))
        return sum(losses) / len(losses)
