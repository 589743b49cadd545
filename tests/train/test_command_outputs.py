"""The train / evaluate / synthesize commands on bad outputs and short splits (issue #16)."""

from __future__ import annotations

import json
import re
import resource
import signal
import subprocess
import sys
import warnings
import wave
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

from gesturebank.app.eval_table import table
from gesturebank.cli.training import train_command
from gesturebank.config import TrainConfig
from gesturebank.datasets.torch import Segment
from gesturebank.errors import InputError
from gesturebank.fileio import atomic_folder, permissions
from gesturebank.robot import pepper
from gesturebank.testing.speech_motion import write_speech_motion_dataset
from gesturebank.train.eval.compare import COLUMNS as COMPARE_COLUMNS
from gesturebank.train.eval.evaluate import (
    FIELD_MEASURES,
    HIGHER,
    LEGEND,
    LOWER,
    MEAN_POSE,
    NATURAL,
    NEAR_NATURAL,
    SEED_MEASURES,
    SHIFTED,
    SHUFFLED,
    TABLE_5_1,
    average,
    evaluate_segments,
)
from gesturebank.train.eval.tables import footnotes, not_computable
from gesturebank.train.synthesis import synthesize

ONE_EPOCH = TrainConfig.model_validate({"mlp": {"max_epochs": 1}, "lstm": {"max_epochs": 1}})


def _write_wav(path: Path, seconds: float, sr: int = 16000) -> None:
    t = np.arange(int(seconds * sr)) / sr
    signal_ = 0.3 * np.sin(2 * np.pi * 220 * t) * (np.sin(2 * np.pi * 2 * t) > 0)
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(sr)
        w.writeframes((signal_ * 32767).astype("<i2").tobytes())


@pytest.fixture(scope="module")
def mlp_model(synthetic_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("model") / "mlp"
    train_command(
        synthetic_dataset,
        model="mlp",
        variant="si",
        fold=0,
        subject=None,
        out_dir=out,
        config=ONE_EPOCH,
        quiet=True,
    )
    return out


def test_si_fold_defaults_to_0(synthetic_dataset: Path, tmp_path: Path) -> None:
    out = tmp_path / "m"
    train_command(
        synthetic_dataset,
        model="mlp",
        variant="si",
        fold=None,
        subject=None,
        out_dir=out,
        config=ONE_EPOCH,
        quiet=True,
    )
    assert json.loads((out / "model.json").read_text())["fold"] == 0


def test_missing_fold_says_why(synthetic_dataset: Path, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no fold 7; the dataset has folds 0–3"):
        train_command(
            synthetic_dataset,
            model="mlp",
            variant="si",
            fold=7,
            subject=None,
            out_dir=tmp_path / "m",
            config=ONE_EPOCH,
        )
    two = write_speech_motion_dataset(tmp_path / "two", subjects=2, seconds=4.0)
    with pytest.raises(InputError, match="at least 3 subjects, the dataset has 2 .*--variant sd"):
        train_command(
            two,
            model="mlp",
            variant="si",
            fold=None,
            subject=None,
            out_dir=tmp_path / "m",
            config=ONE_EPOCH,
        )


def test_training_replaces_the_whole_model_folder(synthetic_dataset: Path, tmp_path: Path) -> None:
    out = tmp_path / "model"
    train_command(
        synthetic_dataset,
        model="lstm",
        variant="si",
        fold=0,
        subject=None,
        out_dir=out,
        config=ONE_EPOCH,
        quiet=True,
    )
    (out / "metrics.json").write_text("{}")  # as evaluate leaves it
    assert (out / "model_step.onnx").is_file()
    train_command(
        synthetic_dataset,
        model="mlp",
        variant="si",
        fold=0,
        subject=None,
        out_dir=out,
        config=ONE_EPOCH,
        quiet=True,
    )
    names = {p.name for p in out.iterdir()}
    assert names == {"weights.pt", "model.json", "normalisers.json", "model.onnx", "loss.png"}
    assert [p.name for p in tmp_path.iterdir()] == ["model"]  # no temporary left beside it


def test_training_refuses_to_wipe_a_folder_that_is_not_a_model(
    synthetic_dataset: Path, tmp_path: Path
) -> None:
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(InputError, match="is not a model folder"):
        train_command(
            synthetic_dataset,
            model="mlp",
            variant="si",
            fold=0,
            subject=None,
            out_dir=tmp_path,
            config=ONE_EPOCH,
            quiet=True,
        )
    assert (tmp_path / "notes.txt").read_text() == "mine"


def test_unwritable_outputs_are_input_errors_naming_the_path(
    synthetic_dataset: Path, mlp_model: Path, tmp_path: Path
) -> None:
    blocker = tmp_path / "file"  # a path under a regular file fails for root too (ENOTDIR)
    blocker.write_text("x")
    with pytest.raises(
        InputError, match=re.escape(f"{blocker / 'm'}: cannot write the model folder")
    ):
        train_command(
            synthetic_dataset,
            model="mlp",
            variant="si",
            fold=0,
            subject=None,
            out_dir=blocker / "m",
            config=ONE_EPOCH,
        )
    wav = tmp_path / "speech.wav"
    _write_wav(wav, 1.0)
    with pytest.raises(
        InputError, match=re.escape(f"{blocker / 'a.csv'}: cannot write the angle CSV")
    ):
        synthesize(mlp_model, audio_path=wav, out_csv=blocker / "a.csv")
    with pytest.raises(InputError, match=re.escape(f"{tmp_path}: cannot write the angle CSV")):
        synthesize(mlp_model, audio_path=wav, out_csv=tmp_path)  # a folder is not a CSV


def _limit_file_size() -> None:
    resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # writes fail with EFBIG instead of a kill


def test_synthesize_keeps_the_old_csv_when_the_write_fails(mlp_model: Path, tmp_path: Path) -> None:
    """A real failing write (a 4 KiB file-size limit on the process): one line, exit 2, the old
    CSV untouched and no partial file, where a plain open had truncated it."""
    wav = tmp_path / "speech.wav"
    _write_wav(wav, 2.0)  # ~20 KB of CSV
    csv = tmp_path / "angles.csv"
    csv.write_text("old\n")
    script = Path(sys.executable).parent / "gesturebank"
    r = subprocess.run(
        [str(script), "synthesize", str(mlp_model), str(wav), "--out", str(csv), "--force"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        preexec_fn=_limit_file_size,
    )
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert lines == [f"error: {csv}: cannot write the angle CSV (File too large)"]
    assert csv.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["angles.csv", "speech.wav"]


def _segments(n: int, subject: str, rng: np.random.Generator) -> Segment:
    profile = pepper.load_profile()
    t = np.arange(n)[:, None] / 100.0
    angles01 = 0.5 + 0.3 * np.sin(2 * np.pi * (0.7 + rng.uniform(0, 1, 11)) * t)
    angles = pepper.denormalise(angles01, profile).astype(np.float32)
    return Segment(
        clip_id=f"{subject}-c",
        subject=subject,
        start=0,
        audio=rng.normal(size=(n, 26)).astype(np.float32),
        target=angles01.astype(np.float32),
        mask=np.ones((n, 11), bool),
        angles=angles,
    )


def _evaluate(segments: list[Segment], rng: np.random.Generator) -> dict:
    config = TrainConfig()
    preds = [np.clip(s.target + rng.normal(0, 0.05, s.target.shape), 0, 1) for s in segments]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning may reach the user
        results = evaluate_segments(
            segments,
            preds,
            name="MLP",
            mean_pose01=np.full(11, 0.5),
            profile=pepper.load_profile(),
            rate_hz=100.0,
            config=config,
        )
        average(results)
        table(results, title="t")
    return results


def test_a_split_shorter_than_the_windows_is_flagged_not_scored() -> None:
    rng = np.random.default_rng(0)
    results = _evaluate([_segments(25, "s0", rng)], rng)  # 0.25 s: < LCCA window, < shift
    rows = results["s0"]
    assert rows["MLP"]["cca"] is None and rows["MLP"]["lcca_theta"] is None  # not 1.000
    assert rows["MLP"]["loss_l"] is not None and rows["MLP"]["delta_jerk"] is not None
    assert "3 s LCCA window (longest 0.25 s)" in rows["MLP"]["not_computable"]["LCCA, CCA, FCCA"]
    shifted = {k: v for k, v in rows[SHIFTED].items() if k not in ("frames", "not_computable")}
    assert all(v is None or set(v.values()) == {None} for v in shifted.values())
    assert rows[SHIFTED]["frames"] == 0 and "every measure" in rows[SHIFTED]["not_computable"]
    assert average(results)[SHIFTED]["loss_l"] is None
    lines = not_computable(results)
    assert any(ln.startswith("s0, shifted truth: every measure not computable") for ln in lines)
    json.dumps(results, allow_nan=False)  # valid JSON: None, not NaN


def test_n_a_reasons_are_named_once_and_columns_say_which_way_is_better() -> None:
    rng = np.random.default_rng(2)
    results = _evaluate([_segments(25, "s0", rng), _segments(25, "s1", rng)], rng)
    absent = {"fgd": "no FGD: no feature autoencoder", "beat_consistency": "no BC: no onsets"}
    notes = footnotes(results, absent)
    # 2 subjects × 5 systems with n/a cells, yet each reason is one line
    assert len(notes.lines) == 4, notes.lines
    cca, every, fgd, _ = notes.lines
    assert cca.startswith("¹ LCCA, CCA, FCCA not computable: no stretch of whole known poses")
    assert cca.endswith(f" — MLP, {NATURAL}, {MEAN_POSE}, {SHUFFLED} of every subject")
    assert every.startswith("² every measure not computable: ") and SHIFTED in every
    assert fgd == "³ no FGD: no feature autoencoder"
    console = Console(record=True, width=300)
    for columns in (TABLE_5_1, SEED_MEASURES, FIELD_MEASURES):
        console.print(table(results, title="t", columns=columns, notes=notes))
    text = console.export_text()
    assert "Loss L ↓" in text and "LCCA_Θ ↑" in text and "Jerk (rad/s³) ≈" in text
    marks = re.findall(r"n/a(\S*)", text)
    assert marks and all(marks), "an n/a without the mark of its reason"
    assert "n/a¹" in text and "n/a²" in text and "n/a³" in text and "n/a⁴" in text
    assert "≈ closer to natural motion's value is better" in LEGEND


def test_each_measure_has_one_name_and_one_direction() -> None:
    columns = [*TABLE_5_1, *SEED_MEASURES, *FIELD_MEASURES]
    keys = [c.key for c in columns]
    assert len(keys) == len(set(keys)) and len({c.header for c in columns}) == len(keys)
    assert all(c.better in (LOWER, HIGHER, NEAR_NATURAL) for c in columns)
    assert set(COMPARE_COLUMNS) <= set(columns)  # compare says it as evaluate does
    assert "H vel" not in {c.header for c in columns}


def test_long_enough_splits_are_scored_without_warnings() -> None:
    rng = np.random.default_rng(1)
    results = _evaluate([_segments(400, "s0", rng), _segments(25, "s1", rng)], rng)
    assert 0 < results["s0"]["MLP"]["cca"] <= 1 and results["s0"]["MLP"]["not_computable"] == {}
    assert results["s0"][MEAN_POSE]["lcca_theta"] == 0.0
    avg = average(results)["MLP"]
    assert avg["cca"] == results["s0"]["MLP"]["cca"]  # the mean over subjects where computable
    assert avg["loss_l"] == pytest.approx(
        (results["s0"]["MLP"]["loss_l"] + results["s1"]["MLP"]["loss_l"]) / 2
    )


def test_model_folder_swap_keeps_the_old_one_on_failure(tmp_path: Path) -> None:
    folder = tmp_path / "m"
    folder.mkdir()
    (folder / "model.json").write_text("old")
    with pytest.raises(KeyboardInterrupt), atomic_folder(folder) as tmp:
        (tmp / "model.json").write_text("new")
        raise KeyboardInterrupt  # Ctrl-C while training
    assert [p.name for p in tmp_path.iterdir()] == ["m"]
    assert (folder / "model.json").read_text() == "old"
    with atomic_folder(folder) as tmp:
        (tmp / "weights.pt").write_text("new")
    assert [p.name for p in folder.iterdir()] == ["weights.pt"]
    assert [p.name for p in tmp_path.iterdir()] == ["m"]
    assert folder.stat().st_mode & 0o777 == permissions(folder=True)  # not mkdtemp's 0700


def test_train_warns_when_the_data_is_too_short_for_a_useful_model(tmp_path: Path) -> None:
    """Issue 44: 3.3 s of data trained and evaluated without a word, the LSTM's 3 s window
    longer than the training split. `train` now says both before training."""
    short = write_speech_motion_dataset(tmp_path / "short", subjects=2, seconds=4.0)
    said: list[str] = []
    train_command(
        short,
        model="lstm",
        variant="sd",
        fold=None,
        subject="s0",
        out_dir=tmp_path / "m",
        config=ONE_EPOCH,
        quiet=True,
        on_warning=said.append,
    )
    assert any("under train.min_train_s (60 s)" in w for w in said), said
    assert any("shorter than lstm's 3 s training window" in w for w in said), said
    said.clear()
    enough = ONE_EPOCH.model_copy(update={"min_train_s": 1.0})
    train_command(
        short,
        model="mlp",
        variant="sd",
        fold=None,
        subject="s0",
        out_dir=tmp_path / "m2",
        config=enough,
        quiet=True,
        on_warning=said.append,
    )
    assert said == []  # frame-wise MLP: no window; 1 s asked for: no warning


def _worse_results(model_rmse: float) -> dict:
    rng = np.random.default_rng(3)
    results = _evaluate([_segments(400, "s0", rng)], rng)
    results["s0"]["MLP"]["rmse_deg"] = model_rmse
    return results


def test_evaluate_says_plainly_when_a_model_is_worse_than_the_mean_pose() -> None:
    """Issue 44: the README's own model was worse than predicting the mean pose (39.3° vs
    18.0°) and nothing said so."""
    from gesturebank.train.eval.tables import worse_lines, worse_than_mean_pose

    worse = _worse_results(1e3)
    base = average(worse)[MEAN_POSE]["rmse_deg"]
    assert worse_than_mean_pose(worse) == {"MLP": (1e3, base)}
    (line,) = worse_lines(worse)
    assert line.startswith("MLP is worse than the mean-pose baseline: RMSE 1000.00° against")
    console = Console(record=True, width=300)
    console.print(table(worse, title="t"))
    rows = [ln for ln in console.export_text().splitlines() if "MLP" in ln]
    assert len(rows) == 2 and all("MLP ✗" in ln for ln in rows)  # the subject's and average
    better = _worse_results(0.0)
    assert worse_than_mean_pose(better) == {} and worse_lines(better) == []


def test_train_picks_a_variant_the_dataset_supports_or_says_which(tmp_path: Path) -> None:
    """Issue 44: the default --variant si failed on any dataset with fewer than 3 subjects, and
    "a subject-dependent split needs a subject" named neither --subject nor the subjects."""
    one = write_speech_motion_dataset(tmp_path / "one", subjects=1, seconds=4.0)
    said: list[str] = []
    train_command(one, model="mlp", variant=None, fold=None, subject=None, out_dir=tmp_path / "m",
                  config=ONE_EPOCH, quiet=True, on_warning=said.append)  # fmt: skip
    info = json.loads((tmp_path / "m" / "model.json").read_text())
    assert (info["variant"], info["subject"]) == ("sd", "s0")
    assert any("its only subject 's0'" in w for w in said), said
    two = write_speech_motion_dataset(tmp_path / "two", subjects=2, seconds=4.0)
    with pytest.raises(InputError, match=r"2 subjects, too few for --variant si.*one of: s0, s1"):
        train_command(
            two,
            model="mlp",
            variant=None,
            fold=None,
            subject=None,
            out_dir=tmp_path / "m2",
            config=ONE_EPOCH,
        )
    with pytest.raises(InputError, match=r"^--variant sd needs --subject, one of: s0, s1$"):
        train_command(
            two,
            model="mlp",
            variant="sd",
            fold=None,
            subject=None,
            out_dir=tmp_path / "m2",
            config=ONE_EPOCH,
        )
    with pytest.raises(InputError, match=r"--subject 's00'.*one of: s0, s1; did you mean 's0'\?"):
        train_command(
            two,
            model="mlp",
            variant="sd",
            fold=None,
            subject="s00",
            out_dir=tmp_path / "m2",
            config=ONE_EPOCH,
        )
