"""Fréchet Gesture Distance (GENEA 2022; Yoon et al. 2020) with a per-dataset feature autoencoder.

FGD = ‖μ_r − μ_g‖² + Tr(Σ_r + Σ_g − 2 (Σ_r Σ_g)^½) between Gaussian fits of the features of
natural (r) and generated (g) motion chunks. The features are the code of a small 1-D conv
autoencoder trained once on the natural motion of a split's train part, and stored with the
dataset:

    <dataset>/fgd/<split>/weights.pt   state dict (torch.load(weights_only=True))
    <dataset>/fgd/<split>/fgd.json     version, training config, digest of the training chunks,
                                       per-joint normaliser, chunk length, loss history

written as one folder swapped in whole (`fileio.atomic_folder`). An FGD is only comparable
under the same autoencoder, so its version — a hash of the weights, the training config and
the training data — is printed beside every FGD. The folder is reused while the training
chunks and config are unchanged and rebuilt otherwise (e.g. after the dataset is rebuilt).

Chunks are `fgd_chunk_s` of whole known poses, resampled to `fgd_rate_hz` (GENEA: 30 fps),
every `fgd_stride_s`; angles are z-normalised per joint with the training chunks' statistics.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import LinAlgWarning, sqrtm
from torch import nn

from gesturebank import __version__
from gesturebank.config import EvalConfig
from gesturebank.errors import InputError
from gesturebank.fileio import atomic_folder, output_errors
from gesturebank.train.torch_runtime import torch_settings

F64 = NDArray[np.float64]
FGD_DIR = "fgd"
WEIGHTS = "weights.pt"
INFO = "fgd.json"
STD_FLOOR = 0.02  # rad (~1°): a joint that barely moves is not blown up by its tiny std
EPS = 1e-6  # covariance offset when (Σ_r Σ_g)^½ is singular, as pytorch-fid does


# --------------------------------------------------------------------------------------------------
# Pure parts


def chunk_frames(*, config: EvalConfig) -> int:
    """Frames per resampled chunk: fgd_chunk_s × fgd_rate_hz, rounded up to a multiple of 4
    (the encoder halves the time axis twice)."""
    n = round(config.fgd_chunk_s * config.fgd_rate_hz)
    return max(4, -(-n // 4) * 4)


def chunks(runs: Sequence[ArrayLike], *, rate_hz: float, config: EvalConfig) -> NDArray[np.float32]:
    """Chunks `(M, L, J)` of stretches `(n_i, J)` of whole known poses at `rate_hz`.

    Each chunk covers `fgd_chunk_s` and is linearly resampled to L = `chunk_frames` frames;
    chunks start every `fgd_stride_s`. A stretch shorter than a chunk gives none.
    """
    length = chunk_frames(config=config)
    span = round(config.fgd_chunk_s * rate_hz)  # source frames per chunk
    hop = max(1, round(config.fgd_stride_s * rate_hz))
    where = np.linspace(0.0, span - 1, length)
    out = []
    for run in runs:
        r = np.asarray(run, dtype=np.float64)
        for a in range(0, len(r) - span + 1, hop):
            piece = r[a : a + span]
            out.append(np.stack([np.interp(where, np.arange(span), c) for c in piece.T], axis=1))
    if not out:
        return np.zeros((0, length, 0), dtype=np.float32)
    return np.asarray(out, dtype=np.float32)


def frechet_distance(*, real: ArrayLike, generated: ArrayLike) -> float:
    """Fréchet distance between Gaussian fits of feature sets `(M, d)` and `(M', d)`."""
    x, y = np.asarray(real, np.float64), np.asarray(generated, np.float64)
    if x.ndim != 2 or y.ndim != 2 or x.shape[1] != y.shape[1] or min(len(x), len(y)) < 2:
        raise ValueError(f"need ≥ 2 feature rows of equal width each, got {x.shape}, {y.shape}")
    mu1, mu2 = x.mean(axis=0), y.mean(axis=0)
    s1, s2 = np.cov(x, rowvar=False), np.cov(y, rowvar=False)
    offset = np.eye(len(s1)) * EPS
    with warnings.catch_warnings():
        warnings.simplefilter("error", LinAlgWarning)
        try:
            covmean = sqrtm(s1 @ s2)
        except LinAlgWarning:  # singular (e.g. a held pose: Σ = 0): offset, as pytorch-fid
            covmean = sqrtm((s1 + offset) @ (s2 + offset))
    if not np.isfinite(covmean).all():
        covmean = sqrtm((s1 + offset) @ (s2 + offset))
    covmean = np.real(covmean)
    d = mu1 - mu2
    return float(max(0.0, d @ d + np.trace(s1) + np.trace(s2) - 2.0 * np.trace(covmean)))


# --------------------------------------------------------------------------------------------------
# The autoencoder


class FeatureAE(nn.Module):
    """Conv encoder (J → h channels, time halved twice) → `features`; a mirrored decoder."""

    def __init__(self, joints: int, length: int, hidden: int, features: int) -> None:
        super().__init__()
        self.hidden, self.quarter = hidden, length // 4
        act = nn.LeakyReLU(0.2)
        self.encoder = nn.Sequential(
            nn.Conv1d(joints, hidden, 3, padding=1),
            act,
            nn.Conv1d(hidden, hidden, 4, stride=2, padding=1),
            act,
            nn.Conv1d(hidden, hidden, 4, stride=2, padding=1),
            act,
            nn.Flatten(),
            nn.Linear(hidden * self.quarter, features),
        )
        self.expand = nn.Linear(features, hidden * self.quarter)
        self.decoder = nn.Sequential(
            act,
            nn.ConvTranspose1d(hidden, hidden, 4, stride=2, padding=1),
            act,
            nn.ConvTranspose1d(hidden, hidden, 4, stride=2, padding=1),
            act,
            nn.Conv1d(hidden, joints, 3, padding=1),
        )

    def encode(self, x: torch.Tensor) -> torch.Tensor:
        """(B, L, J) normalised chunks → (B, features)."""
        return self.encoder(x.transpose(1, 2))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        z = self.expand(self.encode(x)).view(-1, self.hidden, self.quarter)
        return self.decoder(z).transpose(1, 2)


@dataclass(frozen=True, eq=False)
class FeatureModel:
    """A trained FGD autoencoder with its normaliser and version."""

    net: FeatureAE
    mean: F64
    std: F64
    version: str
    path: Path

    @torch.no_grad()
    def features(self, chunked: ArrayLike) -> F64:
        """Features `(M, d)` of chunks `(M, L, J)` from `chunks`."""
        x = (np.asarray(chunked, np.float64) - self.mean) / self.std
        return self.net.encode(torch.from_numpy(x.astype(np.float32))).double().numpy()

    def fgd(self, *, real: ArrayLike, generated: ArrayLike) -> float:
        """FGD between natural and generated chunks `(M, L, J)`."""
        return frechet_distance(real=self.features(real), generated=self.features(generated))


def label(model: FeatureModel | None) -> str:
    """What to print beside FGD numbers: which autoencoder made them."""
    return f"FGD autoencoder {model.version}" if model else "no FGD"


def _digest(data: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(data, dtype=np.float32).tobytes()).hexdigest()


def _settings(config: EvalConfig) -> dict[str, Any]:
    return {k: v for k, v in config.model_dump(mode="json").items() if k.startswith("fgd_")}


def _version(net: FeatureAE, settings: dict[str, Any], data_digest: str) -> str:
    h = hashlib.sha256(json.dumps(settings, sort_keys=True).encode() + data_digest.encode())
    for name, tensor in net.state_dict().items():
        h.update(name.encode() + tensor.detach().contiguous().numpy().tobytes())
    return h.hexdigest()[:12]


def train_feature_ae(
    data: np.ndarray, *, config: EvalConfig, seed: int, threads: int
) -> tuple[FeatureAE, F64, F64, list[float]]:
    """Train the autoencoder on natural chunks `(M, L, J)`: (net, mean (J,), std (J,), losses)."""
    if len(data) < 2:
        raise InputError("FGD needs at least 2 natural motion chunks to train its autoencoder")
    mean = data.reshape(-1, data.shape[2]).mean(axis=0).astype(np.float64)
    std = np.maximum(data.reshape(-1, data.shape[2]).std(axis=0), STD_FLOOR).astype(np.float64)
    x = torch.from_numpy(((data - mean) / std).astype(np.float32))
    losses = []
    with torch_settings(seed, threads):
        net = FeatureAE(data.shape[2], data.shape[1], config.fgd_hidden, config.fgd_features)
        opt = torch.optim.Adam(net.parameters(), lr=config.fgd_learning_rate)
        gen = torch.Generator().manual_seed(seed)
        for _ in range(config.fgd_epochs):
            total = 0.0
            for idx in torch.randperm(len(x), generator=gen).split(config.fgd_batch_size):
                loss = torch.mean((net(x[idx]) - x[idx]) ** 2)
                opt.zero_grad()
                loss.backward()
                opt.step()
                total += float(loss.detach()) * len(idx)
            losses.append(total / len(x))
    net.eval()
    return net, mean, std, losses


def feature_model(
    dataset_path: Path,
    *,
    key: str,
    natural: np.ndarray,
    config: EvalConfig,
    seed: int,
    threads: int,
) -> FeatureModel:
    """The FGD autoencoder of split `key` of the dataset, trained on `natural` chunks
    `(M, L, J)` (its train part's) unless a stored one was trained on the same chunks with the
    same settings."""
    folder = Path(dataset_path) / FGD_DIR / key
    settings = _settings(config)
    digest = _digest(natural)
    stored = _load(folder, settings, digest, natural.shape)
    if stored is not None:
        return stored
    net, mean, std, losses = train_feature_ae(natural, config=config, seed=seed, threads=threads)
    version = _version(net, settings, digest)
    info = {
        "version": version,
        "tool_version": __version__,
        "split": key,
        "settings": settings,
        "seed": seed,
        "data_digest": digest,
        "chunks": len(natural),
        "shape": list(natural.shape[1:]),
        "mean": mean.tolist(),
        "std": std.tolist(),
        "losses": losses,
    }
    with output_errors(folder, "the FGD autoencoder"), atomic_folder(folder) as tmp:
        torch.save(net.state_dict(), tmp / WEIGHTS)
        (tmp / INFO).write_text(json.dumps(info, indent=1))
    return FeatureModel(net, mean, std, version, folder)


def _load(
    folder: Path, settings: dict[str, Any], digest: str, shape: tuple[int, ...]
) -> FeatureModel | None:
    """The stored autoencoder if it matches these settings and training chunks, else None."""
    try:
        info = json.loads((folder / INFO).read_text())
        if info["settings"] != settings or info["data_digest"] != digest:
            return None
        joints, length = shape[2], shape[1]
        net = FeatureAE(joints, length, settings["fgd_hidden"], settings["fgd_features"])
        net.load_state_dict(torch.load(folder / WEIGHTS, weights_only=True))
    except (OSError, ValueError, KeyError, RuntimeError):
        return None  # missing, unreadable or stale: retrain
    net.eval()
    mean, std = np.asarray(info["mean"], np.float64), np.asarray(info["std"], np.float64)
    return FeatureModel(net, mean, std, str(info["version"]), folder)
