"""`gesturebank compare` on the dataset built from the sample media: two models, the baselines,
one table (no quality claim: the demo's speech and motion are unrelated)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console
from typer.testing import CliRunner

from gesturebank.app.compare import compare_command
from gesturebank.cli import app
from gesturebank.cli.training import train_command
from gesturebank.config import TrainConfig
from gesturebank.errors import InputError
from gesturebank.train.eval.compare import COLUMNS
from gesturebank.train.eval.evaluate import LEGEND, MEAN_POSE, NATURAL, SHIFTED, SHUFFLED
from gesturebank.train.eval.tables import units

BASELINES = [NATURAL, MEAN_POSE, SHUFFLED, SHIFTED]
NARROW = {"COLUMNS": "80"}


def at_80_columns(text: str, systems: dict[str, dict[str, float | None]]) -> None:
    """Issue 44: at 80 columns compare's twelve columns were cut (`Loss…`, `RMS…`). Narrow: two
    tables of short headers (units in a line of their own), every value whole, notes wrapped at
    words."""
    lines = [ln for ln in text.splitlines() if not ln.startswith("table written to ")]  # a path
    assert all(len(ln.rstrip()) <= 80 and "…" not in ln for ln in lines), text
    for c in COLUMNS:
        assert f" {c.short}" in text, c.short
    assert units(COLUMNS) in " ".join(ln.strip() for ln in lines), text
    for system, row in systems.items():  # each system's every value, as printed, on its lines
        shown = " ".join(ln for ln in lines if ln.strip().startswith(system))
        for c in COLUMNS:
            if (value := row.get(c.key)) is not None:
                printed = c.fmt.format(value * c.scale)
                assert printed in shown, (system, c.key, printed, text)


@pytest.fixture(scope="module")
def two_models(real_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    cfg = TrainConfig.model_validate(
        {"mlp": {"max_epochs": 5}, "lstm": {"max_epochs": 2, "stride": 20}}
    )
    root = tmp_path_factory.mktemp("models")
    for kind in ("mlp", "lstm"):
        train_command(
            real_dataset,
            model=kind,
            variant="si",
            fold=0,
            subject=None,
            out_dir=root / kind,
            config=cfg,
            quiet=True,
        )
    return [root / "mlp", root / "lstm"]


def test_compare_prints_one_table_and_writes_csv_and_markdown(
    two_models: list[Path], tmp_path: Path
) -> None:
    console = Console(record=True, width=250)
    report = compare_command(two_models, out=tmp_path / "t.csv", console=console)
    text = console.export_text()
    version = report["fgd_version"]
    assert version and f"FGD autoencoder {version}" in text
    assert list(report["systems"]) == ["mlp", "lstm", *BASELINES]
    for name in report["systems"]:
        assert name in text
    natural = report["systems"][NATURAL]
    assert natural["loss_l"] == 0 and natural["fgd"] <= 1e-6  # the truth against itself
    assert report["systems"][MEAN_POSE]["avg_jerk"] == 0
    for name in ("mlp", "lstm"):
        assert np.isfinite(report["systems"][name]["loss_l"])
        assert report["systems"][name]["fgd"] is not None
    with open(tmp_path / "t.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["system"] for r in rows] == list(report["systems"])
    assert {r["fgd_version"] for r in rows} == {version}
    assert float(rows[0]["loss_l"]) == pytest.approx(report["systems"]["mlp"]["loss_l"])
    assert set(rows[0]) == {"system", "fgd_version", *(c.key for c in COLUMNS)}
    assert "H speed ↓" in text and "H vel" not in text  # one measure, one name

    result = CliRunner().invoke(
        app, ["compare", *map(str, two_models), "--out", str(tmp_path / "t.md")], env=NARROW
    )
    assert result.exit_code == 0, result.output
    at_80_columns(result.output, report["systems"])
    md = (tmp_path / "t.md").read_text().splitlines()
    assert f"FGD autoencoder {version}" in md[0]  # the same autoencoder, reused
    assert md[2].startswith("| System | Loss L ↓ | RMSE (°) ↓")
    assert sum(line.startswith("| ") for line in md) == 1 + len(report["systems"])
    assert LEGEND in md  # what ↑, ↓ and ≈ mean, under the table


def test_compare_refuses_models_of_other_splits_and_bad_outputs(
    two_models: list[Path], real_dataset: Path, tmp_path: Path
) -> None:
    with pytest.raises(InputError, match=r"t\.txt: the table is written as \.csv or \.md"):
        compare_command(two_models, out=tmp_path / "t.txt")
    cfg = TrainConfig.model_validate({"mlp": {"max_epochs": 1}})
    other = tmp_path / "fold1"
    train_command(
        real_dataset,
        model="mlp",
        variant="si",
        fold=1,
        subject=None,
        out_dir=other,
        config=cfg,
        quiet=True,
    )
    with pytest.raises(InputError, match="trained on another split or dataset"):
        compare_command([two_models[0], other])
