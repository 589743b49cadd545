"""What the field's measures need from a dataset for one split: the part to score, the other
parts (donors of the shuffled-clip baseline, the FGD autoencoder's natural motion), the FGD
autoencoder itself and the audio onsets of every scored segment.

The autoencoder learns from the train and val parts together, never the test part: on small
datasets the train part alone may hold no chunk of whole known poses (the sample media's has
none of 2 s), and val is not held out from model selection either.

Shared by `evaluate` and `compare`, so both score a split the same way.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from gesturebank.config import TrainConfig
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.store import Dataset
from gesturebank.datasets.torch import Segment, load_segments, split_items
from gesturebank.errors import InputError
from gesturebank.train.eval.evaluate import _runs, segment_onsets
from gesturebank.train.eval.fgd import FeatureModel, chunks, feature_model

if TYPE_CHECKING:
    from gesturebank.train.model_folder import ModelFolder


@dataclass(frozen=True, eq=False)
class SplitInputs:
    """A scored split part and what its field measures need."""

    segments: list[Segment]
    donors: list[Segment]
    fgd: FeatureModel | None
    onsets: list[np.ndarray]
    fgd_note: str | None  # why there is no FGD, when there is none


def split_key(variant: str, *, fold: int | None, subject: str | None, target: str) -> str:
    """A split's folder name under the dataset's fgd/: si-fold00, sd-<subject>, dyadic; with
    "-listener" for the listener target (other motion: the listeners' heads)."""
    key = {"si": f"si-fold{fold or 0:02d}", "dyadic": "dyadic"}.get(variant, f"sd-{subject}")
    return key if target == "speaker" else f"{key}-{target}"


def known_runs(segments: list[Segment]) -> list[np.ndarray]:
    """The stretches `(n, 11)` of whole known poses of each segment's angles."""
    out = []
    for s in segments:
        ok = np.isfinite(s.angles).all(axis=1)
        out += [s.angles[a:b] for a, b in _runs(ok)]
    return out


def _item(segment: Segment) -> tuple[str, int, int]:
    return segment.clip_id, segment.start, segment.start + len(segment)


def prepare(
    dataset: Dataset,
    *,
    variant: str,
    fold: int | None,
    subject: str | None,
    part: str,
    config: TrainConfig,
) -> SplitInputs:
    """Load split part `part` and the train and val parts, train or reuse the FGD autoencoder,
    find the onsets. No FGD (with the reason) when train + val hold fewer than 2 chunks."""
    segments = load_segments(
        dataset,
        split_items(dataset, variant=variant, part=part, fold=fold, subject=subject),
        target=config.target,
    )
    if not segments:
        raise InputError(f"{dataset.path}: the {part} part of this split is empty")
    learn_items = [
        item
        for p in ("train", "val")
        for item in split_items(dataset, variant=variant, part=p, fold=fold, subject=subject)
    ]
    learn = load_segments(dataset, learn_items, target=config.target)
    items = [_item(s) for s in segments]  # the listener target leaves some out
    scored = set(items)
    donors = [s for s in learn if _item(s) not in scored]
    rate_hz = float(dataset.info.rates.pose_hz)
    natural = chunks(known_runs(learn), rate_hz=rate_hz, config=config.eval)
    fgd, note = None, None
    if len(natural) >= 2:
        fgd = feature_model(
            dataset.path,
            key=split_key(variant, fold=fold, subject=subject, target=config.target),
            natural=natural,
            config=config.eval,
            seed=config.seed,
            threads=config.threads,
        )
    else:
        note = (
            f"no FGD: the train and val parts have {len(natural)} chunk(s) of "
            f"{config.eval.fgd_chunk_s:g} s of whole known poses; the autoencoder needs 2"
        )
    raw = []
    cache: dict[str, np.ndarray] = {}
    for clip_id, start, end in items:  # the stored features, before z-normalisation
        if clip_id not in cache:
            cache = {clip_id: dataset.load_arrays(clip_id)["audio"]}
        raw.append(cache[clip_id][start:end])
    onsets = segment_onsets(raw, audio=dataset.info.config.audio, rate_hz=rate_hz, config=config)
    return SplitInputs(segments, donors, fgd, onsets, note)


def prepare_trained(
    folder: ModelFolder,
    dataset: str | os.PathLike[str] | None,
    *,
    part: str,
    config: TrainConfig,
) -> tuple[Dataset, SplitInputs]:
    """`prepare` on the split a model was trained on (its model.json: variant, fold, subject,
    the body parts its clips had), from `dataset`, else the dataset it was trained on."""
    info = folder.info
    ds = open_dataset(dataset or info.need(folder.path, "dataset"), require=info.require)
    variant: str = info.need(folder.path, "variant")
    inputs = prepare(
        ds, variant=variant, fold=info.fold, subject=info.subject, part=part, config=config
    )
    return ds, inputs
