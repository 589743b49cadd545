"""The dataset card DATASET.md: written by the build, its numbers those of the manifest, the
licence and consent of takes.toml in it, a bad takes.toml a one-line error naming the file."""

from __future__ import annotations

import io
import re
import shutil
from pathlib import Path

import pandas as pd
import pytest

from gesturebank.config import Config
from gesturebank.datasets import store
from gesturebank.datasets.card import CARD, card_text, read_takes_toml
from gesturebank.datasets.refresh import refresh
from gesturebank.errors import InputError


def _table(text: str, title: str) -> dict[str, float]:
    """The seconds column of the card's table under the heading starting with `title`."""
    section = text.split(f"## {title}", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| ([^|]+) \| ([0-9.]+) \| [0-9.]+ \|$", section, flags=re.MULTILINE)
    return {name: float(s) for name, s in rows}


def test_card_numbers_agree_with_the_manifest(demo_dataset: Path) -> None:
    text = (demo_dataset / CARD).read_text()
    manifest = pd.read_parquet(demo_dataset / store.MANIFEST)
    accepted = manifest[(manifest.kind == "clip") & (manifest.qc_status == "accepted")]
    assert len(accepted) > 0
    per_subject = accepted.groupby("subject").duration_s.sum()
    assert _table(text, "Kept by subject") == pytest.approx(per_subject.to_dict(), abs=0.051)
    total = re.search(r"^Kept: ([0-9.]+) s", text, flags=re.MULTILINE)
    assert total is not None
    assert float(total.group(1)) == pytest.approx(accepted.duration_s.sum(), abs=0.051)
    for take in manifest.take_id.unique():
        assert f"| {take} |" in text
    for source in manifest.source.unique():
        assert source in text
    parts = _table(text, "Kept by body part")
    assert set(parts) >= {"head", "left arm", "right arm"}
    assert all(0 <= s <= accepted.duration_s.sum() + 0.05 for s in parts.values())
    info = store.read_dataset_json(demo_dataset)
    assert info.config_digest in text and info.tool_version in text


def test_takes_toml_licence_and_consent_appear(demo_dataset: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    shutil.copytree(demo_dataset, out)
    videos = tmp_path / "videos"
    videos.mkdir()
    take = store.take_records(out)[0].take_id
    (videos / "takes.toml").write_text(
        f'["{take}"]\nlicence = "CC BY 4.0"\nconsent = "signed release 2026-03-02"\n'
    )
    refresh(out, Config(), videos_dir=videos)
    rows = [line for line in (out / CARD).read_text().splitlines() if line.startswith("| ")]
    named = [line for line in rows if line.startswith(f"| {take} |")]
    assert len(named) == 1
    assert "CC BY 4.0" in named[0] and "signed release 2026-03-02" in named[0]
    others = [line for line in rows if "__" in line.split(" | ")[0] and line not in named]
    assert others and all("| not stated | not stated |" in line for line in others)


def test_a_bad_takes_toml_key_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "takes.toml"
    path.write_text('[alice]\nlicense = "CC0"\n')  # American spelling: not a key
    with pytest.raises(InputError) as err:
        read_takes_toml(tmp_path)
    message = str(err.value)
    assert str(path) in message and "alice.license" in message and "\n" not in message


def test_a_bad_takes_toml_value_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "takes.toml"
    path.write_text("[alice]\nconsent = 3\n")
    with pytest.raises(InputError, match=r"takes\.toml: alice\.consent"):
        read_takes_toml(tmp_path)


def test_no_takes_toml_says_not_stated() -> None:
    record = store.TakeRecord(
        take_id="t1",
        subject="s1",
        source="a/t1.mp4",
        config_digest="d",
        clips=(
            store.ClipRecord("c1", "clip", 0.0, 10.0, "accepted", duration_s=10.0),
            store.ClipRecord(
                "c2", "clip", 10.0, 14.0, "rejected", ("jerky", "masked"), duration_s=4.0
            ),
            store.ClipRecord("s1", "span", 14.0, 20.0, "rejected", ("speaker unseen",)),
        ),
    )
    info = store.DatasetInfo.model_construct(
        tool_version="9.9",
        videos_dir="/v",
        config_digest="abc123",
        robot_profile="pepper-1.7",
        clip_counts={"accepted": 1, "rejected": 2},
    )
    text = card_text(info=info, records=[record], terms={})
    assert "| t1 | s1 | a/t1.mp4 | not stated | not stated | not stated | 10.0 |" in text
    assert _table(text, "Kept by subject") == {"s1": 10.0}
    assert _table(text, "Not kept") == {"jerky": 4.0, "masked": 4.0, "speaker unseen": 6.0}


def test_a_bad_takes_toml_stops_the_build_before_any_take(tmp_path: Path) -> None:
    from gesturebank.app.build import build_dataset

    videos = tmp_path / "videos"
    videos.mkdir()
    (videos / "takes.toml").write_text('[alice]\nlicense = "CC0"\n')
    with pytest.raises(InputError, match=r"takes\.toml: alice\.license"):
        build_dataset([], videos_dir=videos, out=tmp_path / "out", config=Config())
    assert not (tmp_path / "out" / store.MANIFEST).exists()


def test_one_set_of_counts_in_summary_dashboard_dataset_json_and_card(
    demo_dataset: Path, tmp_path: Path
) -> None:
    """Issue 44: dataset.json and DATASET.md said 2 rejected where the summary and the
    dashboard said 1 rejected clip and 1 dropped stretch. All four now name the same three
    counts the same way."""
    import json
    import os
    import subprocess
    import sys

    dataset = tmp_path / "ds"
    shutil.copytree(demo_dataset, dataset)
    gesturebank = Path(sys.executable).parent / "gesturebank"
    env = {**os.environ, "COLUMNS": "200"}
    cmd = [str(gesturebank), "qc", str(dataset)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False, env=env)
    assert r.returncode == 0, r.stderr
    manifest = pd.read_parquet(dataset / store.MANIFEST)
    clips = manifest[manifest.kind == "clip"]
    spans = manifest[(manifest.kind == "span") & (manifest.qc_status != "failed")]
    truth = {
        "clips kept": int((clips.qc_status == "accepted").sum()),
        "clips rejected": int((clips.qc_status == "rejected").sum()),
        "stretches dropped": len(spans),
    }
    assert truth == {"clips kept": 2, "clips rejected": 1, "stretches dropped": 1}  # the demo
    info = json.loads((dataset / store.DATASET_JSON).read_text())
    assert info["clip_counts"]["accepted"] == truth["clips kept"]
    assert info["clip_counts"]["rejected"] == truth["clips rejected"]
    assert info["stretches_dropped"] == truth["stretches dropped"]
    card = (dataset / CARD).read_text()
    assert ", ".join(f"{name} {n}" for name, n in truth.items()) in card
    index = (dataset / "qc" / "index.html").read_text()
    heads = re.findall(r"<th>([^<]+)</th>", index.split("<table class='big'>", 1)[1])
    cells = re.findall(r"<td id='sum-\d+'>([^<]+)</td>", index)
    shown = dict(zip(heads, cells, strict=False))
    assert {k: int(shown[k].split()[0]) for k in truth} == truth
    table_head = [ln for ln in r.stdout.splitlines() if "clips" in ln and "stretches" in ln]
    assert table_head, r.stdout  # the summary's columns use the same names
    row = next(ln for ln in r.stdout.splitlines() if re.match(r"^│\s+\d", ln))
    numbers = [int(cell) for cell in row.split("│")[3:6]]  # after takes and failed
    assert numbers == list(truth.values()), row


def test_the_summary_table_fits_80_columns(demo_dataset: Path, tmp_path: Path) -> None:
    """Issue 44: at 80 columns the summary's headers were cut (`stret…`, `rejec…`)."""
    import os
    import subprocess
    import sys

    dataset = tmp_path / "ds"
    shutil.copytree(demo_dataset, dataset)
    gesturebank = Path(sys.executable).parent / "gesturebank"
    env = {**os.environ, "COLUMNS": "80"}
    cmd = [str(gesturebank), "qc", str(dataset)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False, env=env)
    assert r.returncode == 0, r.stderr
    table = r.stdout.split("lab__cam01_arctic:", 1)[0].splitlines()
    assert all(len(ln) <= 80 and "…" not in ln for ln in table), r.stdout
    assert "stretches" in r.stdout and "dropped" in r.stdout and "rejected" in r.stdout
    # and each take's line (its rejections and drops with their reasons) was one long line the
    # terminal wrapped: now a block within 80 columns, every reason whole
    lines = [ln for ln in r.stdout.splitlines() if not ln.startswith("QC dashboard: ")]  # a path
    assert all(len(ln.rstrip()) <= 80 for ln in lines), r.stdout
    flowing = " ".join(ln.strip() for ln in lines)
    from gesturebank.datasets import store

    records = store.take_records(dataset)
    reasons = {
        r for t in records for c in t.clips if c.qc_status != "accepted" for r in c.qc_reasons
    }
    assert reasons  # the premise: a clip rejected or a stretch dropped, with its reasons
    for take in records:
        assert any(ln.startswith(f"{take.take_id}: ") for ln in lines), (take.take_id, r.stdout)
    for reason in reasons:
        assert reason in flowing, (reason, r.stdout)
    # the build's own table has three take columns (`takes built`, `skipped`, `failed`): at 80
    # columns its headers were cut (`stretch…`, `reject…`)
    from rich.console import Console

    from gesturebank.app.build import BuildSummary
    from gesturebank.cli.build import print_summary

    screen = Console(width=80, record=True, file=io.StringIO())
    print_summary(screen, BuildSummary(dataset, takes=records))
    built = screen.export_text()
    assert all(len(ln.rstrip()) <= 80 and "…" not in ln for ln in built.splitlines()), built
    for words in ("takes", "built", "skipped", "clips", "rejected", "stretches", "dropped"):
        assert f" {words} " in built, (words, built)
