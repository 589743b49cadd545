"""Issue 33 item 2: `gesturebank clips`, and `replay OUT --clip` naming, suggestions, warnings and
the clip's own source audio — on the dataset built from the real demo videos."""

from __future__ import annotations

import csv
import io
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gesturebank import datasets
from gesturebank.datasets.listing import list_clips, resolve_clip, write_clip_audio
from gesturebank.errors import InputError

BIN = Path(sys.executable).parent
KEPT, REJECTED = "lab__cam01_arctic__c000", "lab__cam03_arctic__c000"
OUTDOOR = "outdoor__sports2d_arctic__c000"


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(BIN / "gesturebank"), *args], capture_output=True, text=True, timeout=300, check=False
    )


def _csv(text: str) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(text)))


def test_clips_lists_every_clip_with_its_verdict(demo_dataset: Path) -> None:
    r = run("clips", str(demo_dataset), "--csv")
    assert r.returncode == 0, r.stderr
    rows = {row["clip"]: row for row in _csv(r.stdout)}
    manifest = datasets.open(demo_dataset).clips(None)
    assert set(rows) == {m.clip.clip_id for m in manifest} == {KEPT, REJECTED, OUTDOOR}
    assert rows[KEPT]["take"] == "lab__cam01_arctic" and rows[KEPT]["subject"] == "lab"
    assert rows[REJECTED]["status"] == "rejected" and "facing away" in rows[REJECTED]["reasons"]
    assert rows[KEPT]["status"] == "accepted" and rows[KEPT]["reasons"] == ""
    for m in manifest:  # span and seconds as the manifest has them
        row = rows[m.clip.clip_id]
        assert float(row["start_s"]) == pytest.approx(m.clip.start_s, abs=1e-3)
        assert float(row["end_s"]) == pytest.approx(m.clip.end_s, abs=1e-3)
        assert float(row["seconds"]) == pytest.approx(m.clip.duration_s, abs=0.01)
        worst_left = max(m.clip.masked[j] for j in m.clip.masked if j.startswith("L"))
        assert ("left arm" in row["masked"]) == (worst_left > 0)


def test_clips_filters(demo_dataset: Path) -> None:
    data = datasets.open(demo_dataset)
    assert [r.clip_id for r in list_clips(data, status="rejected")] == [REJECTED]
    assert {r.clip_id for r in list_clips(data, subject="lab")} == {KEPT, REJECTED}
    assert [r.clip_id for r in list_clips(data, take="outdoor__sports2d_arctic")] == [OUTDOOR]
    assert list_clips(data, subject="lab", status="rejected")[0].clip_id == REJECTED
    r = run("clips", str(demo_dataset), "--status", "accepted", "--subject", "outdoor", "--csv")
    assert r.returncode == 0 and [row["clip"] for row in _csv(r.stdout)] == [OUTDOOR]
    r = run("clips", str(demo_dataset), "--subject", "labb")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "did you mean lab?" in r.stderr
    r = run("clips", str(demo_dataset), "--status", "maybe")
    assert r.returncode == 2 and "accepted" in r.stderr  # the allowed values are named
    r = run("clips", str(demo_dataset))
    assert r.returncode == 0 and REJECTED in r.stdout and "3 clips" in r.stdout


def test_a_take_id_names_its_only_clip_and_a_wrong_one_gets_suggestions(
    demo_dataset: Path,
) -> None:
    data = datasets.open(demo_dataset)
    assert resolve_clip(data, "lab__cam01_arctic").clip_id == KEPT
    assert resolve_clip(data, KEPT).clip_id == KEPT
    with pytest.raises(InputError) as info:
        resolve_clip(data, "lab__cam01_artic")
    assert "did you mean" in str(info.value) and "lab__cam01_arctic" in str(info.value)
    with pytest.raises(InputError, match="gesturebank clips"):
        resolve_clip(data, "nothing-like-it")


def test_a_take_with_several_clips_lists_them(tmp_path: Path) -> None:
    from gesturebank.robot import pepper
    from gesturebank.testing.clips import clip_from_targets, write_dataset

    profile = pepper.load_profile()
    clips = [
        clip_from_targets(
            np.full((300, 11), 0.5), np.zeros((300, 26)), clip_id=f"s1_t__c00{k}", profile=profile
        )
        for k in range(2)
    ]
    write_dataset(tmp_path / "ds", {"s1_t": clips})
    with pytest.raises(InputError) as info:
        resolve_clip(datasets.open(tmp_path / "ds"), "s1_t")
    assert "has 2 clips: s1_t__c000, s1_t__c001" in str(info.value)


def test_replay_of_a_clip_by_take_id_warns_when_rejected(
    demo_dataset: Path, tmp_path: Path
) -> None:
    r = run("replay", str(demo_dataset), "--clip", "lab__cam03_arctic", "--backend", "record",
            "--out", str(tmp_path / "r.jsonl"))  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert r.stderr.startswith(f"warning: clip {REJECTED} was rejected by the QC: facing away")
    r = run("replay", str(demo_dataset), "--clip", "lab__cam01_arctic", "--backend", "record",
            "--out", str(tmp_path / "k.jsonl"))  # fmt: skip
    assert r.returncode == 0 and "warning" not in r.stderr
    r = run("replay", str(demo_dataset), "--clip", "lab__cam01_arctc", "--backend", "record",
            "--out", str(tmp_path / "x.jsonl"))  # fmt: skip
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "lab__cam01_arctic" in r.stderr


def test_clip_audio_is_the_clip_stretch_of_its_source(demo_dataset: Path, tmp_path: Path) -> None:
    """The WAV cut for a clip lines up with the clip's own audio features: the best lag between
    them is the 12.5 ms half window (a frame centred at 0 starts before the clip), not more."""
    from gesturebank.audio.features import features
    from gesturebank.audio.io import read_audio

    data = datasets.open(demo_dataset)
    config = data.info.config.audio
    for clip_id in (KEPT, OUTDOOR):
        row = resolve_clip(data, clip_id)
        wav = write_clip_audio(data, row, out=tmp_path / "a.wav", sample_rate=config.sample_rate)
        assert wav is not None
        track = read_audio(wav, sample_rate=config.sample_rate)
        assert track is not None
        assert len(track.signal) / config.sample_rate == pytest.approx(row.seconds, abs=0.01)
        ours, theirs = (
            features(track.signal, config.sample_rate, config=config),
            data.load(clip_id).audio,
        )
        n = min(len(ours), len(theirs)) - 10
        error = {lag: float(np.abs(ours[:n] - theirs[lag : lag + n]).mean()) for lag in range(6)}
        assert min(error, key=error.__getitem__) == 1, error  # 12.5 ms ≈ one 10 ms frame


def test_sim_replay_of_a_clip_has_its_source_audio(demo_dataset: Path, tmp_path: Path) -> None:
    import av

    out = tmp_path / "clip.mp4"
    small = ["--set", "render.width_px=96", "--set", "render.height_px=72"]
    r = run("replay", str(demo_dataset), "--clip", "outdoor__sports2d_arctic", "--backend", "sim",
            "--out", str(out), *small)  # fmt: skip
    assert r.returncode == 0, r.stderr
    with av.open(str(out)) as container:
        (audio,) = container.streams.audio
        assert audio.duration is not None and audio.time_base is not None
        assert float(audio.duration * audio.time_base) > 5.0  # the 5.6 s clip, not silence
        loud = max(float(np.abs(f.to_ndarray()).max()) for f in container.decode(audio))
    assert loud > 0.05
    silent = tmp_path / "silent.mp4"
    r = run("replay", str(demo_dataset), "--clip", OUTDOOR, "--backend", "sim", "--no-audio",
            "--out", str(silent), *small)  # fmt: skip
    assert r.returncode == 0, r.stderr
    with av.open(str(silent)) as container:
        assert not container.streams.audio


def test_clip_of_something_not_a_dataset_is_one_line(tmp_path: Path) -> None:
    from gesturebank.datasets.listing import clip_to_play
    from gesturebank.robot.timeline import read_timeline

    csv_file = tmp_path / "a.csv"
    csv_file.write_text("time_s\n")
    with pytest.raises(InputError, match="a.csv: --clip plays a clip of a dataset folder"):
        clip_to_play(csv_file, "x", scratch=tmp_path, with_audio=False)
    with pytest.raises(InputError, match="a folder, not an angle timeline .*--clip CLIP_ID"):
        read_timeline(tmp_path)


def test_clips_at_80_columns_keeps_reasons_whole(demo_dataset: Path) -> None:
    """Issue 44: at 80 columns `clips` printed a rejection reason one word per line and cut the
    headers. Narrow: one block per clip, every line within 80, each reason whole."""
    import os

    env = {**os.environ, "COLUMNS": "80"}
    cmd = [str(BIN / "gesturebank"), "clips", str(demo_dataset)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False, env=env)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert all(len(ln.rstrip()) <= 80 and "…" not in ln for ln in lines), r.stdout
    flowing = " ".join(ln.strip() for ln in lines)
    rows = _csv(run("clips", str(demo_dataset), "--csv").stdout)
    assert any(row["reasons"] for row in rows)  # the premise: a rejected clip with reasons
    for row in rows:
        assert any(ln.startswith(row["clip"]) and row["status"] in ln for ln in lines), row
        for reason in filter(None, row["reasons"].split("; ")):
            assert reason in flowing, (reason, r.stdout)
