"""Frame pairs and sequence windows from a split: z-norm per subject, masks, padding, windows."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

import gesturebank.datasets as gds
from gesturebank.config import Config
from gesturebank.datasets.torch import (
    FrameDataset,
    WindowDataset,
    load_segments,
    make_segment,
    masked_mse,
    split_items,
    znorm_stats,
)
from gesturebank.errors import InputError
from gesturebank.train.eval import metrics as M


def _segment(n: int, *, unknown: slice | None = None, seed: int = 0, tid: str = "t"):
    rng = np.random.default_rng(seed)
    angles01 = rng.random((n, 11)).astype(np.float32)
    if unknown is not None:
        angles01[unknown] = np.nan
    audio = (np.arange(n)[:, None] + np.zeros((1, 3))).astype(np.float32)  # row i holds i
    return make_segment(
        tid, subject="s", start=0, audio=audio, angles01=angles01, angles=angles01 * 2
    )


def test_si_items_are_whole_clips_of_disjoint_subjects(synthetic_dataset: Path) -> None:
    ds = gds.open(synthetic_dataset)
    subject = {r.clip.clip_id: r.take.subject for r in ds.clips(None)}
    parts = {p: split_items(ds, variant="si", part=p, fold=1) for p in ("train", "val", "test")}
    subjects = {p: {subject[t] for t, _, _ in items} for p, items in parts.items()}
    assert len(subjects["train"]) == 2 and len(subjects["val"]) == 1 == len(subjects["test"])
    assert not (subjects["train"] & subjects["val"]) and not (subjects["val"] & subjects["test"])
    assert all(a == 0 and b == 1200 for _, a, b in parts["train"])


def test_sd_items_cut_one_subject_by_time(synthetic_dataset: Path) -> None:
    ds = gds.open(synthetic_dataset)
    items = {
        p: split_items(ds, variant="sd", part=p, subject="s2") for p in ("train", "val", "test")
    }
    assert all(t.startswith("s2__") for p in items.values() for t, _, _ in p)
    total = sum(b - a for p in items.values() for _, a, b in p)
    assert total == 2400 and sum(b - a for _, a, b in items["train"]) == 1680
    with pytest.raises(InputError):
        split_items(ds, variant="sd", part="train", subject="nobody")
    with pytest.raises(InputError):
        split_items(ds, variant="si", part="train", fold=None)


def test_audio_is_z_normalised_per_subject(synthetic_dataset: Path) -> None:
    ds = gds.open(synthetic_dataset)
    items = split_items(ds, variant="si", part="test", fold=0)  # all clips of one subject
    segments = load_segments(ds, items)
    audio = np.concatenate([s.audio for s in segments])
    np.testing.assert_allclose(audio.mean(axis=0), 0, atol=1e-4)
    np.testing.assert_allclose(audio.std(axis=0), 1, atol=1e-3)
    raw = np.concatenate([ds.load(t).audio for t, _, _ in items])
    assert np.abs(raw.mean(axis=0)).max() > 0.5  # the raw features were not normalised


def test_unknown_pose_is_masked_not_invented(synthetic_dataset: Path) -> None:
    ds = gds.open(synthetic_dataset)
    seg = load_segments(ds, split_items(ds, variant="si", part="test", fold=0))[0]
    unknown = np.isnan(ds.load(seg.clip_id).angles01)
    assert unknown.any()
    np.testing.assert_array_equal(seg.mask, ~unknown)
    assert np.all(seg.target[unknown] == 0) and np.all(np.isnan(seg.angles[unknown]))


def test_frame_dataset_drops_frames_without_pose() -> None:
    seg = _segment(100, unknown=slice(10, 30))
    data = FrameDataset([seg, _segment(50, seed=1)])
    assert len(data) == 80 + 50
    x, _y, m = data[10]
    assert float(x[0]) == 30.0 and bool(m.all())  # frame 30 follows frame 9
    xb, yb, mb = data.batch(torch.tensor([0, 1, 2]))
    assert xb.shape == (3, 3) and yb.shape == (3, 11) and mb.dtype == torch.bool


def test_windows_stay_inside_segments_with_stride() -> None:
    a, b = _segment(40, tid="a"), _segment(25, seed=1, tid="b")
    data = WindowDataset([a, b], seq_len=10, stride=7)
    # a: starts 0, 7, 14, 21, 28 and the last full window 30; b: 0, 7, 14 and 15.
    assert len(data) == 6 + 4
    x, _y, _m = data[5]
    assert x.shape == (10, 3) and float(x[0, 0]) == 30.0 and float(x[-1, 0]) == 39.0
    x, _, _ = data[6]
    assert float(x[0, 0]) == 0.0  # first window of b, not a mix of a and b
    assert len(WindowDataset([a], seq_len=10, stride=1)) == 31  # stride 1: every start


def test_short_segments_are_padded_and_masked() -> None:
    short = _segment(6)
    data = WindowDataset([short], seq_len=10, stride=1)
    assert len(data) == 1
    x, _y, m = data[0]
    assert x.shape == (10, 3) and bool(m[:6].all()) and not bool(m[6:].any())
    assert float(x[6:].abs().sum()) == 0.0


def test_windows_without_any_pose_are_dropped() -> None:
    seg = _segment(30, unknown=slice(0, 20))
    data = WindowDataset([seg], seq_len=10, stride=5)
    starts = [int(s) for s in data.starts]
    assert starts == [15, 20]  # windows 0–9 and 5–14 have no known frame; 10–19 neither
    xb, yb, _mb = data.batch(torch.arange(len(data)))
    assert xb.shape == (2, 10, 3) and yb.shape == (2, 10, 11)


def test_masked_mse_is_loss_l_over_known_entries() -> None:
    seg = _segment(20, unknown=slice(3, 8))
    pred = np.random.default_rng(5).random((20, 11)).astype(np.float32)
    truth = np.where(seg.mask, seg.target, np.nan)
    loss = masked_mse(
        torch.from_numpy(pred), torch.from_numpy(seg.target), mask=torch.from_numpy(seg.mask)
    )
    assert float(loss) == pytest.approx(M.loss_l(truth, pred), rel=1e-6)


def test_every_subject_has_stats_even_with_only_rejected_clips(tmp_path: Path) -> None:
    """The z-norm stats cover every subject with a clip: a rejected clip's motion is bad, its
    audio is not (and a split that includes rejected clips needs them)."""
    from gesturebank.robot import pepper
    from gesturebank.testing.clips import clip_from_targets, write_dataset

    rng = np.random.default_rng(0)
    profile = pepper.load_profile()
    takes = {}
    for subject, unknown in (("good", 0), ("bad", 350)):
        t = np.arange(400)[:, None] / 100
        angles01 = 0.5 + 0.1 * np.sin(2 * np.pi * 0.5 * t + rng.uniform(0, 6, 11))
        angles01[:unknown] = np.nan  # head and arms unseen in most of it
        audio = rng.normal(5.0, 2.0, (400, 26))
        takes[f"{subject}_t"] = [
            clip_from_targets(angles01, audio, clip_id=f"{subject}_t__c000", profile=profile)
        ]
    # rejected by the whole-clip rule (opt-in since issue 32; a build masks such parts whole)
    whole = Config.model_validate({"qc": {"max_head_unknown_fraction": 0.5}})
    ds = gds.open(write_dataset(tmp_path, takes, config=whole))
    assert ds.clip_ids("rejected") == ["bad_t__c000"]
    mean, std = znorm_stats(ds, "bad")
    audio = takes["bad_t"][0].audio.astype(np.float64)
    np.testing.assert_allclose(mean, audio.mean(axis=0), rtol=1e-6)
    np.testing.assert_allclose(std, audio.std(axis=0), rtol=1e-5)
    with pytest.raises(InputError, match="no audio normalisation"):
        znorm_stats(ds, "nobody")
