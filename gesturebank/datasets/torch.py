"""PyTorch datasets over a built dataset's splits: frame pairs (MLP) and sequence windows (LSTM).

A split part (SI fold or SD subject, see `datasets.splits`) is loaded as `Segment`s — one per
clip (SI) or per (clip, start, end) piece (SD). Audio features are z-normalised with the stats of
the segment's own subject from dataset.json (`normalisation.audio_znorm_by_subject`, §3.2), which
is how the dissertation normalised every speaker, test speakers included.

Unknown pose (NaN in `angles01`) is handled with a mask, never by inventing values:
- every segment carries `mask (n, 11)`, True where the target angle is known; the target holds 0
  where it is not, and the loss (`masked_mse`) averages over known entries only;
- `FrameDataset` drops frames with no known angle at all (they carry no signal);
- `WindowDataset` keeps audio continuous (the LSTM needs its context even where pose is unknown),
  masks the unknown targets, and drops windows with no known target. A segment shorter than
  `seq_len` is padded at its end with zero audio and mask 0: the LSTM is causal, so padding after
  a frame never changes that frame's output.
Frames whose audio is not finite are zeroed and masked too.

The listener target (`load_segments(..., target="listener")`, seed 004) loads only the clips with
a partner, adds the partner's speaking flag as one more input column and keeps only the head
angles on the clip's listening frames as known (`datasets.listener`).
"""

from __future__ import annotations

import difflib
import json
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import torch
from torch.utils.data import Dataset as TorchDataset

from gesturebank.audio.features import apply_znorm
from gesturebank.config import Target
from gesturebank.datasets.listener import listener_inputs, listener_mask
from gesturebank.datasets.reader import Dataset
from gesturebank.datasets.splits import SPLITS_DIR, subject_independent
from gesturebank.errors import InputError

log = logging.getLogger(__name__)

SplitItem = tuple[str, int, int]  # (clip_id, start_frame, end_frame)
Batch = tuple[torch.Tensor, torch.Tensor, torch.Tensor]  # x, y, mask


@dataclass(frozen=True)
class Segment:
    """A contiguous piece of one clip, ready for a model.

    audio: (n, F) float32 z-normalised features; target: (n, 11) float32 angles in [0, 1] with
    unknown entries 0; mask: (n, 11) bool, True where the target is known; angles: (n, 11)
    float32 radians, NaN where unknown (for metrics); role: (n,) int8, the clip's role track
    (`clip.ROLES` codes), None when not loaded.
    """

    clip_id: str
    subject: str
    start: int
    audio: np.ndarray
    target: np.ndarray
    mask: np.ndarray
    angles: np.ndarray
    role: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.audio)


def split_items(
    dataset: Dataset,
    *,
    variant: str,
    part: str,
    fold: int | None = None,
    subject: str | None = None,
) -> list[SplitItem]:
    """(clip_id, start, end) items of one part ('train' | 'val' | 'test') of a split.

    SI: `fold` selects splits/si_fold_XX.json, whole clips. SD: `subject` selects that subject's
    segments in splits/sd.json. Dyadic: splits/dyadic.json, whole clips. Clips without the body
    parts the dataset was opened to require (`datasets.open(..., require=)`) are left out.
    """
    if part not in ("train", "val", "test"):
        raise InputError(f"split part must be train, val or test, got {part!r}")
    folder = dataset.path / SPLITS_DIR
    n_frames = {r.clip.clip_id: r.clip.n_frames for r in dataset.clips(None)}
    if variant == "si":
        if fold is None:
            raise InputError("a subject-independent split needs a fold number")
        path = folder / f"si_fold_{fold:02d}.json"
        if not path.is_file():
            raise _missing_fold(dataset, fold)
        spec = _read_json(path)
        return [(t, 0, n_frames[t]) for t in spec[part] if t in n_frames]
    if variant == "dyadic":
        path = folder / "dyadic.json"
        if not path.is_file():
            raise InputError(
                f"{folder}: no dyadic split: no clip has a partner (build with "
                'build.people = "all" on footage of two people)'
            )
        return [(t, 0, n_frames[t]) for t in _read_json(path)[part] if t in n_frames]
    if variant == "sd":
        spec = _read_json(folder / "sd.json")
        subjects = sorted(spec["subjects"])
        if subject is None:
            raise InputError(f"--variant sd needs --subject, {_subjects_text(subjects)}")
        if subject not in spec["subjects"]:
            close = difflib.get_close_matches(subject, subjects, n=1, cutoff=0.6)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise InputError(
                f"--subject {subject!r}: not a subject of {dataset.path}, "
                f"{_subjects_text(subjects)}{hint}"
            )
        items = spec["subjects"][subject][part]
        return [(str(t), int(a), int(b)) for t, a, b in items if str(t) in n_frames]
    raise InputError(f"variant must be 'si', 'sd' or 'dyadic', got {variant!r}")


def _subjects_text(subjects: list[str]) -> str:
    """'one of: a, b' — or why there is none (never an empty list)."""
    if subjects:
        return f"one of: {', '.join(subjects)}"
    return "but the dataset has no subject with usable clips (see `gesturebank clips`)"


def choose_variant(
    dataset: Dataset, *, variant: str | None, fold: int | None, subject: str | None
) -> tuple[str, str | None, str | None]:
    """The split `train` uses when --variant (or --subject) is not given: si when the dataset
    has subject-independent folds (or a --fold is given), sd when a --subject is, else sd of
    its only subject. Returns (variant, subject, a note saying what was chosen, or None);
    InputError naming the choices when none fits."""
    folder = dataset.path / SPLITS_DIR
    if variant not in (None, "sd"):
        return variant, subject, None
    if variant is None and (fold is not None or any(folder.glob("si_fold_*.json"))):
        return "si", subject, None
    if subject is not None:
        return "sd", subject, None
    subjects = sorted(_read_json(folder / "sd.json")["subjects"])
    if len(subjects) == 1:
        why = "" if variant == "sd" else ", --variant sd (si needs 3 subjects)"
        return "sd", subjects[0], f"training on its only subject {subjects[0]!r}{why}"
    if variant == "sd":
        raise InputError(f"--variant sd needs --subject, {_subjects_text(subjects)}")
    raise InputError(
        f"{dataset.path}: {len(subjects)} subjects, too few for --variant si (needs 3); train "
        f"with --variant sd --subject NAME, {_subjects_text(subjects)}"
    )


def _missing_fold(dataset: Dataset, fold: int) -> InputError:
    """Why fold `fold` has no file: another fold number, too few subjects, or stale splits."""
    folder = dataset.path / SPLITS_DIR
    folds = sorted(int(p.stem.removeprefix("si_fold_")) for p in folder.glob("si_fold_*.json"))
    if folds:
        return InputError(f"{folder}: no fold {fold}; the dataset has folds {folds[0]}–{folds[-1]}")
    try:  # the rule that decided not to write them, asked again
        subject_independent(dataset.manifest.to_pylist(), config=dataset.info.config.splits)
    except InputError as exc:
        return InputError(f"{dataset.path}: {exc}; train with --variant sd")
    return InputError(f"{folder}: no subject-independent folds (rewrite them: gesturebank qc)")


def _read_json(path: Any) -> Any:
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"{path}: split not found (rebuild the dataset's splits)") from None
    except ValueError as exc:
        raise InputError(f"{path}: not valid JSON ({exc})") from None


def znorm_stats(dataset: Dataset, subject: str) -> tuple[np.ndarray, np.ndarray]:
    """(mean, std) `(F,)` of a subject's audio features ("*" = all subjects).

    From dataset.json, which holds them for every subject with a clip.
    """
    stats = dataset.info.audio_znorm_by_subject
    if subject not in stats:
        raise InputError(f"{dataset.path}: no audio normalisation for subject {subject!r}")
    return np.asarray(stats[subject].mean), np.asarray(stats[subject].std)


def load_segments(
    dataset: Dataset, items: Sequence[SplitItem], *, target: Target | None = None
) -> list[Segment]:
    """Load the items' frames, z-normalise audio per subject, build targets and masks.

    target: "speaker" (None: the same) — every known angle of every item; "listener"
    (`datasets.listener`) — the items of clips with a partner, the partner's speaking flag as
    one more input column, only head angles on listening frames known; items without any are
    left out."""
    subjects = {r.clip.clip_id: r.take.subject for r in dataset.clips(None)}
    stats: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    cache: dict[str, dict[str, np.ndarray]] = {}
    out = []
    for clip_id, start, end in items:
        if clip_id not in cache:
            cache = {clip_id: dataset.load_arrays(clip_id)}  # items come grouped by clip
        arrays = cache[clip_id]
        subject = subjects[clip_id]
        if subject not in stats:
            stats[subject] = znorm_stats(dataset, subject)
        mean, std = stats[subject]
        audio = apply_znorm(arrays["audio"][start:end], mean, std=std)
        angles01 = np.asarray(arrays["angles01"][start:end], dtype=np.float32)
        angles = np.asarray(arrays["angles"][start:end], dtype=np.float32)
        role = np.asarray(arrays["role"], np.int8)[start:end]
        segment: Segment | None = make_segment(
            clip_id,
            subject=subject,
            start=start,
            audio=audio,
            angles01=angles01,
            angles=angles,
            role=role,
        )
        if target == "listener" and segment is not None:
            segment = _as_listener(segment, arrays, start, end)
        if segment is not None:
            out.append(segment)
    return out


def _as_listener(
    segment: Segment, arrays: Mapping[str, np.ndarray], start: int, end: int
) -> Segment | None:
    """The segment as a listener example (`datasets.listener`); None when its clip has no
    partner or it has no known head angle on a listening frame."""
    if not str(arrays["partner_clip_id"]):
        return None
    assert segment.role is not None  # load_segments reads it
    mask = listener_mask(mask=segment.mask, role=segment.role)
    if not mask.any():
        return None
    speaking = np.asarray(arrays["partner_speaking"][start:end], bool)
    return replace(
        segment,
        audio=listener_inputs(audio=segment.audio, partner_speaking=speaking),
        target=np.where(mask, segment.target, 0.0).astype(np.float32),
        mask=mask,
        angles=np.where(mask, segment.angles, np.nan).astype(np.float32),  # scored there only
    )


def make_segment(
    clip_id: str,
    *,
    subject: str,
    start: int,
    audio: np.ndarray,
    angles01: np.ndarray,
    angles: np.ndarray,
    role: np.ndarray | None = None,
) -> Segment:
    """A Segment from z-normalised audio `(n, F)` and angles `(n, 11)` (NaN = unknown), with
    the role track `(n,)` when known."""
    audio = np.asarray(audio, dtype=np.float32)
    bad_audio = ~np.isfinite(audio).all(axis=1)
    mask = np.isfinite(angles01) & ~bad_audio[:, None]
    return Segment(
        clip_id=clip_id,
        subject=subject,
        start=start,
        audio=np.where(bad_audio[:, None], 0.0, audio).astype(np.float32),
        target=np.where(mask, angles01, 0.0).astype(np.float32),
        mask=mask,
        angles=np.where(np.isfinite(angles01), angles, np.nan).astype(np.float32),
        role=role,
    )


def masked_mse(pred: torch.Tensor, target: torch.Tensor, *, mask: torch.Tensor) -> torch.Tensor:
    """Mean of (pred − target)² over the known entries (loss L, Eq. 3.15, NaN-free)."""
    m = mask.to(pred.dtype)
    return ((pred - target) ** 2 * m).sum() / m.sum().clamp_min(1.0)


class FrameDataset(TorchDataset[Batch]):
    """Frame-wise pairs for the MLP: item i = (x (F,), y (11,), mask (11,)).

    Frames of all segments are stacked; frames without any known angle are dropped.
    """

    def __init__(self, segments: Sequence[Segment]) -> None:
        if not segments:
            raise InputError("no segments to build a frame dataset from")
        mask = np.concatenate([s.mask for s in segments])
        keep = mask.any(axis=1)
        self.x = torch.from_numpy(np.concatenate([s.audio for s in segments])[keep])
        self.y = torch.from_numpy(np.concatenate([s.target for s in segments])[keep])
        self.mask = torch.from_numpy(mask[keep])
        if len(self.x) == 0:
            raise InputError("no frame with a known pose in these segments")

    def __len__(self) -> int:
        return len(self.x)

    def __getitem__(self, i: int) -> Batch:
        return self.x[i], self.y[i], self.mask[i]

    def batch(self, idx: torch.Tensor) -> Batch:
        """Items `idx (B,)` stacked: x (B, F), y (B, 11), mask (B, 11)."""
        return self.x[idx], self.y[idx], self.mask[idx]


class WindowDataset(TorchDataset[Batch]):
    """Sequence windows for the LSTM: item i = (x (L, F), y (L, 11), mask (L, 11)), L = seq_len.

    Windows start every `stride` frames within a segment (never across segments); when the
    stride does not land on a segment's last full window, that window is added so the end is
    covered. Segments shorter than L are padded (module docstring).
    """

    def __init__(self, segments: Sequence[Segment], seq_len: int, stride: int) -> None:
        if not segments:
            raise InputError("no segments to build a window dataset from")
        if seq_len < 1 or stride < 1:
            raise InputError("seq_len and stride must be positive")
        self.seq_len = seq_len
        xs, ys, ms = [], [], []
        starts: list[int] = []
        offset = 0
        for s in segments:
            n = len(s)
            pad = max(0, seq_len - n)
            xs.append(np.pad(s.audio, ((0, pad), (0, 0))))
            ys.append(np.pad(s.target, ((0, pad), (0, 0))))
            ms.append(np.pad(s.mask, ((0, pad), (0, 0))))
            last = n + pad - seq_len
            local = list(range(0, last + 1, stride))
            if local[-1] != last:
                local.append(last)
            starts.extend(offset + a for a in local)
            offset += n + pad
        self.x = torch.from_numpy(np.concatenate(xs))
        self.y = torch.from_numpy(np.concatenate(ys))
        self.mask = torch.from_numpy(np.concatenate(ms))
        st = torch.tensor(starts, dtype=torch.long)
        # Drop windows with no known target: a cumulative count of known frames per window.
        known = torch.cat([torch.zeros(1), torch.cumsum(self.mask.any(dim=1).double(), 0)])
        self.starts = st[(known[st + seq_len] - known[st]) > 0]
        if len(self.starts) == 0:
            raise InputError("no window with a known pose in these segments")
        self._steps = torch.arange(seq_len)

    def __len__(self) -> int:
        return len(self.starts)

    def __getitem__(self, i: int) -> Batch:
        a = int(self.starts[i])
        b = a + self.seq_len
        return self.x[a:b], self.y[a:b], self.mask[a:b]

    def batch(self, idx: torch.Tensor) -> Batch:
        """Windows `idx (B,)` stacked: x (B, L, F), y (B, L, 11), mask (B, L, 11)."""
        rows = self.starts[idx][:, None] + self._steps[None, :]
        return self.x[rows], self.y[rows], self.mask[rows]
