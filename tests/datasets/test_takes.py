from pathlib import Path

import pytest

from gesturebank.config import BuildConfig
from gesturebank.datasets.takes import discover_takes, take_id
from gesturebank.errors import ConfigError, InputError


def touch(root: Path, *names: str) -> None:
    for n in names:
        (root / n).parent.mkdir(parents=True, exist_ok=True)
        (root / n).write_bytes(b"")


def test_ids_subjects_from_folders_and_sidecar_wav(tmp_path: Path) -> None:
    touch(tmp_path, "anna/talk 1.mp4", "anna/talk 1.wav", "bob/x.MOV", "notes.txt", ".hidden/y.mp4")
    takes = discover_takes(tmp_path)
    assert [(t.take_id, t.subject) for t in takes] == [("anna__talk_1", "anna"), ("bob__x", "bob")]
    assert takes[0].audio == tmp_path / "anna/talk 1.wav"
    assert takes[1].audio is None


def test_subjects_csv_wins_then_pattern(tmp_path: Path) -> None:
    touch(tmp_path, "day1/p07_story.mp4", "day1/p08_story.mp4")
    cfg = BuildConfig(subject_pattern=r"(?P<subject>p\d+)_")
    assert [t.subject for t in discover_takes(tmp_path, cfg)] == ["p07", "p08"]
    (tmp_path / "subjects.csv").write_text("take,subject,extraversion\np07_story,alice,4.5\n")
    takes = discover_takes(tmp_path, cfg)
    assert [t.subject for t in takes] == ["alice", "p08"]
    assert takes[0].traits == {"extraversion": "4.5"}


def test_bad_inputs(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not a directory"):
        discover_takes(tmp_path / "missing")
    touch(tmp_path, "a/x.mp4")
    with pytest.raises(ConfigError, match="subject_pattern"):
        discover_takes(tmp_path, BuildConfig(subject_pattern="(unclosed"))
    (tmp_path / "subjects.csv").write_text("video,who\n")
    with pytest.raises(InputError, match="subjects.csv: needs the columns"):
        discover_takes(tmp_path)


def test_colliding_ids_are_an_error(tmp_path: Path) -> None:
    assert take_id(Path("a b/c.mp4")) == take_id(Path("a_b/c.mp4"))
    touch(tmp_path, "a b/c.mp4", "a_b/c.mp4")
    with pytest.raises(InputError, match="same take id"):
        discover_takes(tmp_path)
