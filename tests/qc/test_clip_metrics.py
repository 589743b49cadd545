"""`ClipMetrics`: the names a check can use, a misspelt metric refused at load, and the flat
mapping on disk read back as it was written."""

from __future__ import annotations

import json
import math
from dataclasses import fields, replace
from pathlib import Path
from typing import get_args

import pytest

from gesturebank.config import MetricName, QCConfig, load_config
from gesturebank.errors import ConfigError
from gesturebank.qc.checks import THRESHOLDS, absolute_reasons
from gesturebank.qc.clip_metrics import METRIC_NAMES, ClipMetrics
from gesturebank.qc.invariants import HOLDS, InvariantMetrics, invariant_reasons
from gesturebank.qc.metrics import clip_metrics
from gesturebank.robot import pepper


def test_the_config_names_the_single_number_metrics() -> None:
    """config.py sits below qc and writes the names again: the two lists stay equal."""
    assert get_args(MetricName) == METRIC_NAMES
    numbers = {f.name for f in fields(ClipMetrics) if f.type in ("float", "float | None")}
    assert set(METRIC_NAMES) == numbers
    assert set(THRESHOLDS) <= set(METRIC_NAMES)  # every absolute check names a metric


def test_a_misspelt_outlier_metric_fails_at_load(tmp_path: Path) -> None:
    path = tmp_path / "gesturebank.toml"
    path.write_text('[qc]\noutlier_metrics = ["jerk_raw", "jerk_rwa"]\n', encoding="utf-8")
    with pytest.raises(ConfigError, match=r"qc\.outlier_metrics"):
        load_config(path)
    assert QCConfig(outlier_metrics=["spike_max"]).outlier_metrics == ["spike_max"]


def _text(metrics: dict[str, float]) -> str:
    return json.dumps(metrics, allow_nan=True)  # NaN == NaN, and the keys in their order


def test_the_stored_mapping_reads_back_as_written(clip) -> None:
    measured = clip_metrics(clip, profile=pepper.load_profile(), qc=QCConfig())
    assert measured.trimmed_fraction is None  # of the take, not of the clip
    stored = replace(measured, trimmed_fraction=0.25).to_dict()
    assert list(stored)[:3] == ["duration_s", "jerk_raw", "jerk"]
    assert list(stored)[-1] == "trimmed_fraction"
    for joint in pepper.JOINTS:
        for family in ("jerk_raw", "jerk", "out_of_reach", "frozen_at_limit_s"):
            assert f"{family}/{joint}" in stored
    assert stored["invariant/speed"] == HOLDS and "invariant/speed_joint" not in stored
    again = ClipMetrics.from_dict(stored)
    assert _text(again.to_dict()) == _text(stored)
    assert again.value("spike_max") == measured.spike_max
    with pytest.raises(KeyError):
        again.value("jerk_rwa")


def test_metrics_measured_before_the_invariants_break_none() -> None:
    """An old record without the invariant keys (or any other number) fails no check."""
    old = ClipMetrics.from_dict({"jerk_raw": 1e6})
    assert math.isnan(old.invariants.speed) and old.invariants.speed_ratio is None
    assert math.isnan(old.spike_max) and old.trimmed_fraction is None
    assert absolute_reasons(old, QCConfig()) == []


def test_a_broken_invariant_reads_back_with_its_numbers() -> None:
    broken = InvariantMetrics(speed=12.0, speed_ratio=3.5, speed_joint=2.0)
    again = InvariantMetrics.from_dict(broken.to_dict())
    assert again == broken
    (reason,) = invariant_reasons(again, QCConfig())
    assert reason.startswith(f"invariant speed broken at frame 12: {pepper.JOINTS[2]} steps 3.5×")
