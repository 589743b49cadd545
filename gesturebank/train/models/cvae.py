"""The CVAE (seed 004, Greenwood et al.): motion sampled from speech.

Encoder Q(z | motion, audio): a BLSTM over the chunk's [motion, audio] frames, its outputs
averaged over the known frames → μ, log σ² of z (one z per chunk, `latent` = 3). Decoder
P(motion | audio, z): a BLSTM over [audio, z] per frame → angles in [0, 1]. Loss per chunk:
masked MSE of the reconstruction + `kl_weight` × KL(q ‖ N(0, I)) / known entries, i.e. both
per predicted value (a unit-variance Gaussian ELBO up to a constant factor). At synthesis z is
drawn from N(0, I) — different z, different motion for the same speech; `forward` without z
uses z = 0, the prior's mean, so validation is deterministic. Seed 004's RMSprop schedule.
"""

from __future__ import annotations

import torch
from torch import nn

from gesturebank.config import TrainConfig
from gesturebank.datasets.torch import masked_mse
from gesturebank.train.schedule import Schedule, rmsprop_schedule

N_ANGLES = 11


def kl_to_standard_normal(mu: torch.Tensor, logvar: torch.Tensor) -> torch.Tensor:
    """KL(N(μ, diag σ²) ‖ N(0, I)) per row of `(N, D)` → `(N,)`, in closed form."""
    return 0.5 * (logvar.exp() + mu**2 - 1.0 - logvar).sum(dim=-1)


class CVAE(nn.Module):
    """decode: audio `(B, T, F)`, z `(B, latent)` → `(B, T, 11)` in [0, 1]."""

    kind = "cvae"
    causal = False
    config_sections = ("cvae",)

    def __init__(
        self, n_features: int, layers: int, units: int, latent: int, kl_weight: float
    ) -> None:
        super().__init__()
        self.n_features, self.layers, self.units = n_features, layers, units
        self.latent, self.kl_weight = latent, kl_weight
        self.encoder = nn.LSTM(N_ANGLES + n_features, units, num_layers=layers,
                               batch_first=True, bidirectional=True)  # fmt: skip
        self.to_q = nn.Linear(2 * units, 2 * latent)
        self.decoder = nn.LSTM(n_features + latent, units, num_layers=layers,
                               batch_first=True, bidirectional=True)  # fmt: skip
        self.out = nn.Linear(2 * units, N_ANGLES)

    def encode(
        self, x: torch.Tensor, y: torch.Tensor, m: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """(μ, log σ²) `(B, latent)` of q(z | motion y, audio x); unknown targets are 0."""
        h, _ = self.encoder(torch.cat([y, x], dim=-1))
        known = m.any(dim=-1, keepdim=True).to(h.dtype)  # average over frames with a pose
        pooled = (h * known).sum(dim=1) / known.sum(dim=1).clamp_min(1.0)
        mu, logvar = self.to_q(pooled).chunk(2, dim=-1)
        return mu, logvar

    def decode(self, x: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        zs = z[:, None, :].expand(-1, x.shape[1], -1)
        h, _ = self.decoder(torch.cat([x, zs], dim=-1))
        return torch.sigmoid(self.out(h))

    def forward(self, x: torch.Tensor, z: torch.Tensor | None = None) -> torch.Tensor:
        if z is None:
            z = x.new_zeros(x.shape[0], self.latent)
        return self.decode(x, z)

    def loss(self, x: torch.Tensor, y: torch.Tensor, m: torch.Tensor) -> torch.Tensor:
        mu, logvar = self.encode(x, y, m)
        z = mu + (0.5 * logvar).exp() * torch.randn_like(mu)  # reparameterisation
        recon = masked_mse(self.decode(x, z), y, mask=m)
        kl = kl_to_standard_normal(mu, logvar).sum() / m.sum().clamp_min(1.0)
        return recon + self.kl_weight * kl

    def schedule(self, config: TrainConfig) -> Schedule:
        return rmsprop_schedule(config.cvae, config)

    def onnx_inputs(self) -> dict[str, tuple[int, ...]]:
        """Graph inputs beside the audio: z, one row per sequence."""
        return {"z": (1, self.latent)}
