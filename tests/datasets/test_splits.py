import json
from collections import Counter
from pathlib import Path

import pytest

from gesturebank.config import SplitsConfig
from gesturebank.datasets.splits import subject_dependent, subject_independent, write_splits
from gesturebank.errors import InputError


def manifest(n_subjects: int, takes_per_subject: int = 2, frames: int = 1000) -> list[dict]:
    return [
        {
            "take_id": f"s{s:02d}_t{t}",
            "subject": f"s{s:02d}",
            "qc_status": "accepted",
            "n_frames": frames + 10 * t,
        }
        for s in range(n_subjects)
        for t in range(takes_per_subject)
    ]


def test_si_folds_match_table_4_4() -> None:
    folds = subject_independent(manifest(19), 10)
    assert len(folds) == 10
    subjects = {f"s{s:02d}" for s in range(19)}
    sizes = Counter(tuple(len(f["subjects"][p]) for p in ("train", "val", "test")) for f in folds)
    assert sizes[(15, 2, 2)] == 8  # the dissertation's 15/2/2; one group has a single subject
    tested = Counter(s for f in folds for s in f["subjects"]["test"])
    assert set(tested) == subjects
    assert set(tested.values()) == {1}  # each subject is tested exactly once
    for f in folds:
        parts = [set(f["subjects"][p]) for p in ("train", "val", "test")]
        assert set.union(*parts) == subjects
        assert sum(map(len, parts)) == 19  # disjoint
        for p in ("train", "val", "test"):  # a take goes where its subject goes
            assert {t.split("_")[0] for t in f[p]} == set(f["subjects"][p])


def test_si_is_seeded_and_needs_three_subjects() -> None:
    assert subject_independent(manifest(7), seed=3) == subject_independent(manifest(7), seed=3)
    assert subject_independent(manifest(7), seed=3) != subject_independent(manifest(7), seed=4)
    assert len(subject_independent(manifest(4), 10)) == 4  # k never exceeds the subject count
    with pytest.raises(InputError, match="at least 3 subjects"):
        subject_independent(manifest(2))


def test_rejected_excluded_unless_asked_failed_never() -> None:
    m = manifest(4)
    m[0]["qc_status"] = "rejected"
    m[1]["qc_status"] = "failed"
    every = {t for f in subject_independent(m, include_rejected=False) for t in f["test"]}
    assert "s00_t0" not in every and "s00_t1" not in every
    every = {t for f in subject_independent(m, include_rejected=True) for t in f["test"]}
    assert "s00_t0" in every and "s00_t1" not in every


def test_sd_cuts_each_subject_by_time() -> None:
    m = manifest(3, takes_per_subject=3, frames=333)
    sd = subject_dependent(m)
    for subject, parts in sd["subjects"].items():
        takes = [r for r in m if r["subject"] == subject]
        total = sum(r["n_frames"] for r in takes)
        count = {p: sum(e - s for _, s, e in parts[p]) for p in ("train", "val", "test")}
        assert sum(count.values()) == total  # every frame exactly once
        assert count["train"] == round(0.7 * total)
        assert count["train"] + count["val"] == round(0.85 * total)
        # time order: train before val before test, segments inside their takes
        timeline = [(t, s, e) for p in ("train", "val", "test") for t, s, e in parts[p]]
        flat = [(t, f) for t, s, e in timeline for f in (s, e)]
        assert flat == sorted(flat)
        length = {r["take_id"]: r["n_frames"] for r in takes}
        assert all(0 <= s < e <= length[t] for t, s, e in timeline)


def test_write_splits(tmp_path: Path) -> None:
    notes = write_splits(tmp_path, manifest(5), SplitsConfig(folds=10))
    assert notes == []
    assert len(list((tmp_path / "splits").glob("si_fold_*.json"))) == 5
    notes = write_splits(tmp_path, manifest(2), SplitsConfig(folds=10))
    assert "at least 3 subjects" in notes[0]
    assert list((tmp_path / "splits").glob("si_fold_*.json")) == []  # no stale folds
    assert json.loads((tmp_path / "splits" / "sd.json").read_text())["variant"] == "sd"


def test_rejected_takes_enter_the_splits_only_when_asked(tmp_path: Path) -> None:
    m = manifest(3)
    m[0]["qc_status"] = "rejected"
    write_splits(tmp_path, m, SplitsConfig())
    sd = json.loads((tmp_path / "splits" / "sd.json").read_text())
    listed = {t for parts in sd["subjects"].values() for p in parts.values() for t, _, _ in p}
    assert "s00_t0" not in listed
    write_splits(tmp_path, m, SplitsConfig(include_rejected=True))
    sd = json.loads((tmp_path / "splits" / "sd.json").read_text())
    listed = {t for parts in sd["subjects"].values() for p in parts.values() for t, _, _ in p}
    assert "s00_t0" in listed
