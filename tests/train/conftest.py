"""Datasets shared by the train tests: a generated one (always) and one from real media."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

import gesturebank.datasets as gds
from gesturebank.config import SplitsConfig, TrainConfig
from gesturebank.datasets.splits import SPLITS_DIR, subject_independent
from gesturebank.testing.speech_motion import write_speech_motion_dataset


@pytest.fixture(scope="session")
def synthetic_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """4 subjects × 2 takes × 12 s; arms follow the audio envelope, head and shoulder rolls a
    low-passed, delayed copy of it (see gesturebank.testing.speech_motion)."""
    return write_speech_motion_dataset(tmp_path_factory.mktemp("synthetic") / "ds")


@pytest.fixture()
def fast_config() -> TrainConfig:
    """Small enough for seconds on one core; LSTM sequences of 1 s (the lag is 0.1 s, τ 0.25 s)."""
    return TrainConfig.model_validate(
        {
            "learning_rate": 0.01,
            "mlp": {"batch_size": 256, "max_epochs": 200},
            "lstm": {"seq_len": 100, "stride": 5, "batch_size": 32, "max_epochs": 200},
        }
    )


@pytest.fixture(scope="session")
def real_dataset(samples: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The 3 talking clips of the sample media as 3 subjects (SI folds need ≥ 3), built for real."""
    from gesturebank.app.build import build_dataset
    from gesturebank.config import Config
    from gesturebank.datasets.takes import discover_takes

    talking = samples / "talking"
    clips = sorted(talking.glob("*/*.mp4"))
    assert len(clips) >= 3, f"expected 3 talking clips under {talking}"
    videos = tmp_path_factory.mktemp("real") / "videos"
    for i, clip in enumerate(clips[:3]):
        (videos / f"subject{i}").mkdir(parents=True)
        shutil.copy(clip, videos / f"subject{i}" / clip.name)
    out = videos.parent / "dataset"
    summary = build_dataset(discover_takes(videos), videos_dir=videos, out=out, config=Config())
    assert not summary.failed, summary.failed
    # QC may reject these clips; the test is about training on real data, not its quality,
    # so the SI folds are rewritten to include rejected clips.
    records = gds.open(out).manifest.to_pylist()
    for fold in subject_independent(records, config=SplitsConfig(include_rejected=True)):
        path = out / SPLITS_DIR / f"si_fold_{fold['fold']:02d}.json"
        path.write_text(json.dumps(fold, indent=1))
    return out
