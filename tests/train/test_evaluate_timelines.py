"""`evaluate --timelines`: other systems' angle timelines scored like a model (issue 33, 1)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

import gesturebank.datasets as gds
from gesturebank.cli.training import evaluate_command, evaluate_timelines_command, train_command
from gesturebank.config import TrainConfig
from gesturebank.datasets.listing import clip_timeline
from gesturebank.datasets.torch import split_items
from gesturebank.errors import InputError
from gesturebank.robot.timeline import Timeline, read_timeline, write_timeline
from gesturebank.train.eval.evaluate import NATURAL, SHIFTED
from gesturebank.train.eval.timelines import sample

# measures the 1 µrad rounding of the file's cells leaves as natural motion's (not the CCA
# family: the synthetic arms mirror each other, collinear columns rounding makes not quite so)
EQUAL_TO_NATURAL = {
    "jerk_pred": 1e-2,
    "avg_accel": 1e-2,
    "avg_jerk": 1e-2,
    "hellinger_speed": 1e-2,
    "hellinger_accel": 1e-2,
    "fgd": 1e-2,
    "beat_consistency": 1e-2,
}


def _test_clips(dataset: Path) -> list[str]:
    return sorted(
        {c for c, _, _ in split_items(gds.open(dataset), variant="si", part="test", fold=0)}
    )


def _write_truth(dataset: Path, folder: Path, shift_s: float = 0.0) -> list[Path]:
    """The test clips' own ground-truth angles as timelines, optionally `shift_s` late."""
    paths = []
    for clip_id in _test_clips(dataset):
        line = clip_timeline(dataset, clip_id)
        line = replace(line, times=line.times + shift_s)
        paths.append(write_timeline(folder / f"{clip_id}.csv", line))
    return paths


def test_sample_interpolates_and_holds_the_ends() -> None:
    line = Timeline.of([0.0, 1.0], np.array([[0.0] * 11, [2.0] * 11]))
    got = sample(line, np.array([-1.0, 0.25, 1.0, 3.0]))
    np.testing.assert_allclose(got[:, 4], [0.0, 0.5, 2.0, 2.0])


def test_sample_holds_masked_cells_as_the_reader_does(tmp_path: Path) -> None:
    angles = np.zeros((3, 11))
    angles[:, 2] = [0.1, np.nan, 0.3]  # an unknown cell between two known ones
    path = write_timeline(tmp_path / "c.csv", Timeline.of([0.0, 0.01, 0.02], angles))
    got = sample(read_timeline(path), np.array([0.0, 0.01, 0.02]))
    np.testing.assert_allclose(got[:, 2], [0.1, 0.1, 0.3], atol=1e-6)


def test_ground_truth_timelines_score_as_natural_motion_and_shifted_ones_worse(
    synthetic_dataset: Path, tmp_path: Path
) -> None:
    _write_truth(synthetic_dataset, tmp_path / "truth")
    shift = TrainConfig().shift_baseline_s  # the shifted-truth baseline's delay
    _write_truth(synthetic_dataset, tmp_path / "late", shift_s=shift)
    console = Console(record=True, width=250)
    report = evaluate_timelines_command(
        [tmp_path / "truth", tmp_path / "late"], dataset=synthetic_dataset, console=console
    )
    rows = report["average"]
    truth, late, natural = rows["truth"], rows["late"], rows[NATURAL]
    assert truth["rmse_deg"] < 1e-3 and truth["loss_l"] < 1e-10  # cells rounded to 1 µrad
    assert truth["ape_deg"] < 1e-3 and truth["lcca_theta"] == pytest.approx(1.0, abs=1e-4)
    for key, tol in EQUAL_TO_NATURAL.items():
        assert truth[key] == pytest.approx(natural[key], rel=tol, abs=tol), key
    assert late["rmse_deg"] > 1.0 and late["lcca_theta"] < truth["lcca_theta"] - 0.05
    # the baseline's own delay: its error, but for the first `shift` s (the file's first pose
    # held there, where the baseline scores nothing)
    assert late["rmse_deg"] == pytest.approx(rows[SHIFTED]["rmse_deg"], rel=0.2)
    text = console.export_text()
    assert "truth" in text and "late" in text and "natural motion" in text


def test_timelines_score_beside_a_model(
    synthetic_dataset: Path, fast_config: TrainConfig, tmp_path: Path
) -> None:
    cfg = fast_config.model_copy(
        update={"mlp": fast_config.mlp.model_copy(update={"max_epochs": 2})}
    )
    model = tmp_path / "mlp"
    train_command(
        synthetic_dataset,
        model="mlp",
        variant="si",
        fold=0,
        subject=None,
        out_dir=model,
        config=cfg,
        quiet=True,
    )
    _write_truth(synthetic_dataset, tmp_path / "other")
    report = evaluate_command(model, timelines=[tmp_path / "other"], console=Console(width=250))
    assert {"MLP-SI", "other", NATURAL} <= report["average"].keys()
    assert report["average"]["other"]["rmse_deg"] < 1e-3


def test_cli_scores_timelines_without_a_model(synthetic_dataset: Path, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from gesturebank.cli import app

    paths = _write_truth(synthetic_dataset, tmp_path / "sys")
    ok = CliRunner().invoke(
        app, ["evaluate", str(synthetic_dataset), "--timelines", str(tmp_path / "sys")]
    )
    assert ok.exit_code == 0, ok.output
    assert "sys" in ok.output and "natural motion" in ok.output
    paths[0].unlink()
    bad = CliRunner().invoke(
        app, ["evaluate", str(synthetic_dataset), "--timelines", str(tmp_path / "sys")]
    )
    assert bad.exit_code == 2
    lines = [ln for ln in bad.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and str(paths[0]) in lines[0], bad.output


def _one_line_error(exc: pytest.ExceptionInfo[InputError], *parts: str) -> None:
    message = str(exc.value)
    assert "\n" not in message
    for part in parts:
        assert part in message, message


def test_a_missing_clip_names_the_file(synthetic_dataset: Path, tmp_path: Path) -> None:
    paths = _write_truth(synthetic_dataset, tmp_path / "sys")
    paths[-1].unlink()
    with pytest.raises(InputError) as exc:
        evaluate_timelines_command([tmp_path / "sys"], dataset=synthetic_dataset)
    _one_line_error(exc, str(paths[-1]), "no timeline for clip")


def test_a_bad_header_names_the_file(synthetic_dataset: Path, tmp_path: Path) -> None:
    paths = _write_truth(synthetic_dataset, tmp_path / "sys")
    text = paths[0].read_text().replace("HeadYaw", "HeadYawn", 1)
    paths[0].write_text(text)
    with pytest.raises(InputError) as exc:
        evaluate_timelines_command([tmp_path / "sys"], dataset=synthetic_dataset)
    _one_line_error(exc, str(paths[0]), "HeadYaw")


def test_another_robot_profile_names_the_file(synthetic_dataset: Path, tmp_path: Path) -> None:
    paths = _write_truth(synthetic_dataset, tmp_path / "sys")
    want = gds.open(synthetic_dataset).info.robot_profile
    paths[0].write_text(paths[0].read_text().replace(f"profile: {want}", "profile: nao-6", 1))
    with pytest.raises(InputError) as exc:
        evaluate_timelines_command([tmp_path / "sys"], dataset=synthetic_dataset)
    _one_line_error(exc, str(paths[0]), "nao-6", want)


def test_every_angle_dialect_reads_back_through_evaluate(
    synthetic_dataset: Path, tmp_path: Path
) -> None:
    """Issue 44 item 10: the angle-format round trip (issue 33: what export writes, replay and
    export read) also reads back through `evaluate --timelines`: the test clips' own angles in
    radians as `export --format csv` writes them, in degrees with a `# unit: deg` line and in
    `_deg` columns all score as the ground truth."""
    import subprocess
    import sys

    from gesturebank.robot.pepper import JOINTS

    exe = Path(sys.executable).parent / "gesturebank"
    ds = gds.open(synthetic_dataset)
    for dialect in ("exported", "unit_deg", "deg_columns"):
        (tmp_path / dialect).mkdir()
    for clip_id in _test_clips(synthetic_dataset):
        npz = next(ds.path.glob(f"takes/*/{clip_id}.npz"))
        out = tmp_path / "exported" / f"{clip_id}.csv"
        cmd = [str(exe), "export", str(npz), "--format", "csv", "--out", str(out)]
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
        assert r.returncode == 0, r.stderr
        line = read_timeline(out)
        cells = [
            [f"{a:.9g}" if np.isfinite(a) else "" for a in np.degrees(row)] for row in line.angles
        ]
        rows = "".join(
            f"{float(t)!r}," + ",".join(row) + "\n"
            for t, row in zip(line.times, cells, strict=True)
        )
        head = f"time_s,{','.join(JOINTS)}\n"
        (tmp_path / "unit_deg" / f"{clip_id}.csv").write_text(f"# unit: deg\n{head}{rows}")
        deg_head = f"time_s,{','.join(j + '_deg' for j in JOINTS)}\n"
        (tmp_path / "deg_columns" / f"{clip_id}.csv").write_text(deg_head + rows)
    dirs = [tmp_path / d for d in ("exported", "unit_deg", "deg_columns")]
    report = evaluate_timelines_command(dirs, dataset=synthetic_dataset, console=Console(width=250))
    for name in ("exported", "unit_deg", "deg_columns"):
        assert report["average"][name]["rmse_deg"] < 1e-3, (name, report["average"][name])
