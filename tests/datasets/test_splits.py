import json
from collections import Counter
from pathlib import Path

import pytest

from gesturebank.config import SplitsConfig
from gesturebank.datasets.splits import (
    dyadic,
    partner_groups,
    subject_dependent,
    subject_independent,
    write_splits,
)
from gesturebank.errors import InputError


def manifest(n_subjects: int, takes_per_subject: int = 2, frames: int = 1000) -> list[dict]:
    """Manifest rows: two clips per take and a dropped span between them."""
    rows = []
    for s in range(n_subjects):
        for t in range(takes_per_subject):
            take = f"s{s:02d}_t{t}"
            for k, kind in enumerate(("clip", "span", "clip")):
                rows.append(
                    {
                        "clip_id": f"{take}__{kind[0]}{k:03d}",
                        "take_id": take,
                        "kind": kind,
                        "start_s": 100.0 * k,
                        "subject": f"s{s:02d}",
                        "qc_status": "accepted" if kind == "clip" else "rejected",
                        "n_frames": frames + 10 * t + k if kind == "clip" else 0,
                    }
                )
    return rows[::-1]  # any order: the splits put clips in time order


def test_si_folds_match_table_4_4() -> None:
    folds = subject_independent(manifest(19), config=SplitsConfig(folds=10))
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
        for p in ("train", "val", "test"):  # a clip goes where its subject goes
            assert {t.split("_")[0] for t in f[p]} == set(f["subjects"][p])
            assert all("__c" in t for t in f[p])  # clips only, never dropped spans


def test_si_is_seeded_and_needs_three_subjects() -> None:
    def seeded(seed: int) -> list[dict[str, object]]:
        return subject_independent(manifest(7), config=SplitsConfig(seed=seed))

    assert seeded(3) == seeded(3)
    assert seeded(3) != seeded(4)
    ten = SplitsConfig(folds=10)
    assert len(subject_independent(manifest(4), config=ten)) == 4  # k never exceeds the subjects
    with pytest.raises(InputError, match="at least 3 subjects"):
        subject_independent(manifest(2), config=SplitsConfig())


def test_rejected_excluded_unless_asked_failed_never() -> None:
    m = manifest(4)
    status = {"s00_t0__c000": "rejected", "s00_t0__c002": "failed"}
    for r in m:
        r["qc_status"] = status.get(r["clip_id"], r["qc_status"])
    every = {t for f in subject_independent(m, config=SplitsConfig()) for t in f["test"]}
    assert "s00_t0__c000" not in every and "s00_t0__c002" not in every
    assert "s00_t1__c000" in every
    with_rejected = SplitsConfig(include_rejected=True)
    every = {t for f in subject_independent(m, config=with_rejected) for t in f["test"]}
    assert "s00_t0__c000" in every and "s00_t0__c002" not in every


def test_sd_cuts_each_subject_by_time() -> None:
    m = manifest(3, takes_per_subject=3, frames=333)
    sd = subject_dependent(m, config=SplitsConfig())
    for subject, parts in sd["subjects"].items():
        clips = [r for r in m if r["subject"] == subject and r["kind"] == "clip"]
        total = sum(r["n_frames"] for r in clips)
        count = {p: sum(e - s for _, s, e in parts[p]) for p in ("train", "val", "test")}
        assert sum(count.values()) == total  # every frame exactly once
        assert count["train"] == round(0.7 * total)
        assert count["train"] + count["val"] == round(0.85 * total)
        # time order: train before val before test, segments inside their clips
        timeline = [(t, s, e) for p in ("train", "val", "test") for t, s, e in parts[p]]
        flat = [(t, f) for t, s, e in timeline for f in (s, e)]
        assert flat == sorted(flat)
        length = {r["clip_id"]: r["n_frames"] for r in clips}
        assert all(0 <= s < e <= length[t] for t, s, e in timeline)


def test_write_splits(tmp_path: Path) -> None:
    notes = write_splits(tmp_path, records=manifest(5), config=SplitsConfig(folds=10))
    assert notes == []
    assert len(list((tmp_path / "splits").glob("si_fold_*.json"))) == 5
    notes = write_splits(tmp_path, records=manifest(2), config=SplitsConfig(folds=10))
    assert "at least 3 subjects" in notes[0]
    assert list((tmp_path / "splits").glob("si_fold_*.json")) == []  # no stale folds
    assert json.loads((tmp_path / "splits" / "sd.json").read_text())["variant"] == "sd"


def test_rejected_clips_enter_the_splits_only_when_asked(tmp_path: Path) -> None:
    m = manifest(3)
    for r in m:
        if r["clip_id"] == "s00_t0__c000":
            r["qc_status"] = "rejected"
    write_splits(tmp_path, records=m, config=SplitsConfig())
    sd = json.loads((tmp_path / "splits" / "sd.json").read_text())
    listed = {t for parts in sd["subjects"].values() for p in parts.values() for t, _, _ in p}
    assert "s00_t0__c000" not in listed and "s00_t0__c002" in listed
    assert not any("__s" in t for t in listed)  # dropped spans never
    write_splits(tmp_path, records=m, config=SplitsConfig(include_rejected=True))
    sd = json.loads((tmp_path / "splits" / "sd.json").read_text())
    listed = {t for parts in sd["subjects"].values() for p in parts.values() for t, _, _ in p}
    assert "s00_t0__c000" in listed


def seed_004_corpus(utterances: int = 3600) -> list[dict]:
    """Manifest rows shaped like seed 004's corpus (§3.1): two actors, 3600 utterances, each
    filmed as the speaker's clip and the listener's clip of the same moment, paired; the actors
    take turns at speaking (A speaks the even utterances)."""
    rows = []
    for u in range(utterances):
        take = f"dyad_t{u // 100:02d}"
        speaker, listener = ("A", "B") if u % 2 == 0 else ("B", "A")
        ids = (f"{take}__c{2 * (u % 100):03d}", f"{take}__c{2 * (u % 100) + 1:03d}")
        for own, partner, actor in ((ids[0], ids[1], speaker), (ids[1], ids[0], listener)):
            rows.append(
                {
                    "clip_id": own,
                    "take_id": take,
                    "kind": "clip",
                    "start_s": 6.0 * (u % 100),
                    "subject": actor,
                    "qc_status": "accepted",
                    "n_frames": 600,
                    "partner_clip_id": partner,
                }
            )
    return rows


def leaks(split: dict, rows: list[dict]) -> list[str]:
    """Test clips whose partner is in train or validation (seed 004 §7's constraint)."""
    partner = {r["clip_id"]: r["partner_clip_id"] for r in rows}
    seen = set(split["train"]) | set(split["val"])
    return [c for c in split["test"] if partner.get(c) in seen]


def test_dyadic_split_reproduces_seed_004s_counts_and_keeps_partners_apart() -> None:
    """Seed 004 §5 splits its 3600 utterances 85 / 10 / 5 %: 3060 / 360 / 180. On a table of
    its size the dyadic split gives exactly those utterances (pairs) per part, and no test
    clip's partner is in train or validation."""
    rows = seed_004_corpus()
    split = dyadic(rows, config=SplitsConfig())
    assert [len(split[p]) // 2 for p in ("train", "val", "test")] == [3060, 360, 180]
    assert all(len(split[p]) % 2 == 0 for p in ("train", "val", "test"))
    assert leaks(split, rows) == []
    every = split["train"] + split["val"] + split["test"]
    assert sorted(every) == sorted(r["clip_id"] for r in rows) and len(set(every)) == len(every)
    # both actors are tested, as speaker and as listener
    subject = {r["clip_id"]: r["subject"] for r in rows}
    assert {subject[c] for c in split["test"]} == {"A", "B"}
    # the same 85/10/5 cut of single clips, blind to partners, would leak (the rule matters)
    blind = dyadic([{**r, "partner_clip_id": ""} for r in rows], config=SplitsConfig())
    assert len(leaks(blind, rows)) > 100


def test_partner_chains_stay_in_one_part_and_unpaired_clips_still_split() -> None:
    """A listener's clip overlapping two clips of the speaker links all three; clips without a
    partner are split one by one."""
    rows = [
        {"clip_id": "t__c000", "partner_clip_id": "t__c001"},
        {"clip_id": "t__c001", "partner_clip_id": "t__c000"},
        {"clip_id": "t__c002", "partner_clip_id": "t__c001"},
        {"clip_id": "t__c003", "partner_clip_id": "gone__c000"},  # its partner is not usable
        {"clip_id": "u__c000", "partner_clip_id": ""},
    ]
    assert partner_groups(rows) == [["t__c000", "t__c001", "t__c002"], ["t__c003"], ["u__c000"]]


def test_dyadic_json_is_written_only_when_clips_have_partners(tmp_path: Path) -> None:
    write_splits(tmp_path, records=manifest(3))
    assert not (tmp_path / "splits" / "dyadic.json").exists()
    rows = seed_004_corpus(200)
    write_splits(tmp_path, records=rows)
    written = json.loads((tmp_path / "splits" / "dyadic.json").read_text())
    assert written["variant"] == "dyadic" and written["paired_clips"] == 400
    assert leaks(written, rows) == []
    write_splits(tmp_path, records=manifest(3))  # rebuilt without partners: no stale dyadic split
    assert not (tmp_path / "splits" / "dyadic.json").exists()
