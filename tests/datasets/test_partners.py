"""Partners (`datasets.partners`): clips of two people of one take that overlap in time are
paired, the partner's speaking track is sampled at the clip's times, and the store refuses a
take whose partners break the rule (another person, the same take, overlapping)."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import gesturebank.datasets
from gesturebank.clip import Clip, parts_label, parts_of
from gesturebank.datasets import store
from gesturebank.datasets.partners import (
    SPEAKING,
    Voice,
    check_partners,
    overlap_s,
    pair_clips,
    pair_voices,
)
from gesturebank.errors import InputError
from gesturebank.testing.clips import synthetic_clip, write_dataset
from gesturebank.testing.dyads import with_person

HOP = 0.01


def person_clip(clip_id: str, person: int, start_s: float, seconds: float, role: int) -> Clip:
    c = replace(synthetic_clip(seconds=seconds, clip_id=clip_id), start_s=start_s)
    return with_person(c, person=person, role=np.full(len(c.times), role, np.int8))


def voice(clip_id: str, person: int, start_s: float, n: int, speaking=None) -> Voice:
    spoken = np.zeros(n, bool) if speaking is None else np.asarray(speaking, bool)
    return Voice(clip_id, person, start_s + HOP * np.arange(n), spoken)


def test_two_people_at_the_same_time_are_paired_with_the_partners_speech() -> None:
    rng = np.random.default_rng(0)
    a = voice("t__c000", 0, 10.0, 300, rng.random(300) < 0.5)
    b = voice("t__c001", 1, 10.5, 300, rng.random(300) < 0.5)  # starts 50 frames later
    pairs = pair_voices([a, b])
    assert pairs["t__c000"][0] == "t__c001" and pairs["t__c001"][0] == "t__c000"
    a_hears = pairs["t__c000"][1]
    assert not a_hears[:50].any()  # before b's clip starts
    np.testing.assert_array_equal(a_hears[50:], b.speaking[:250])
    b_hears = pairs["t__c001"][1]
    np.testing.assert_array_equal(b_hears[:250], a.speaking[50:])
    assert not b_hears[250:].any()  # after a's clip ends


def test_no_partner_for_the_same_person_or_without_overlap() -> None:
    same = [voice("t__c000", 0, 0.0, 200), voice("t__c001", 0, 1.0, 200)]
    assert pair_voices(same) == {}
    apart = [voice("t__c000", 0, 0.0, 200), voice("t__c001", 1, 2.0, 200)]  # touch, no overlap
    assert pair_voices(apart) == {}


def test_the_longest_overlap_is_the_partner() -> None:
    a = voice("t__c000", 0, 0.0, 500)
    short = voice("t__c001", 1, 0.0, 100)
    long = voice("t__c002", 1, 1.0, 400)
    pairs = pair_voices([a, short, long])
    assert pairs["t__c000"][0] == "t__c002"
    assert pairs["t__c001"][0] == "t__c000" and pairs["t__c002"][0] == "t__c000"


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, 2), st.integers(0, 800), st.integers(1, 400)),
        min_size=1,
        max_size=6,
    )
)
def test_every_pair_is_another_person_overlapping_and_every_overlap_is_paired(spec) -> None:
    voices = [voice(f"t__c{k:03d}", p, HOP * s, n) for k, (p, s, n) in enumerate(spec)]
    pairs = pair_voices(voices)
    by_id = {v.clip_id: v for v in voices}
    for v in voices:
        overlapping = [o for o in voices if o.person != v.person and overlap_s(v, o) > 0]
        assert (v.clip_id in pairs) == bool(overlapping)
        if v.clip_id in pairs:
            partner = by_id[pairs[v.clip_id][0]]
            assert partner.person != v.person and overlap_s(v, partner) > 0
            assert overlap_s(v, partner) == max(overlap_s(v, o) for o in overlapping)
            assert pairs[v.clip_id][1].shape == (len(v.times_s),)


def test_pair_clips_reads_person_and_role_and_the_store_keeps_the_pairs(tmp_path: Path) -> None:
    speaker = person_clip("s1_t__c000", 0, 0.0, 4.0, role=SPEAKING)
    listener = person_clip("s1_t__c001", 1, 1.0, 4.0, role=2)
    paired = pair_clips([speaker, listener])
    assert [c.partner_clip_id for c in paired] == ["s1_t__c001", "s1_t__c000"]
    hears = paired[1].partner_speaking  # the listener, 1 s later, hears the speaker to its end
    shared = len(speaker.times) - 100
    assert hears[:shared].all() and not hears[shared:].any()
    assert not paired[0].partner_speaking.any()  # the listener never speaks
    out = write_dataset(tmp_path, {"s1_t": paired}, in_turn=False)
    ds = gesturebank.datasets.open(out)
    loaded = ds.load("s1_t__c001")
    assert loaded.partner_clip_id == "s1_t__c000"
    np.testing.assert_array_equal(loaded.partner_speaking, hears)
    manifest = pq.read_table(out / "manifest.parquet").to_pydict()
    assert dict(zip(manifest["clip_id"], manifest["partner_clip_id"], strict=True)) == {
        "s1_t__c000": "s1_t__c001",
        "s1_t__c001": "s1_t__c000",
    }


def _record(take_id: str, clips: list[Clip]) -> store.TakeRecord:
    rows = tuple(
        store.ClipRecord(
            c.clip_id,
            "clip",
            c.start_s,
            c.start_s + c.duration_s,
            "accepted",
            parts=parts_label(parts_of(c.mask)),
            partner_clip_id=c.partner_clip_id,
        )
        for c in clips
    )
    return store.TakeRecord(take_id, "s1", f"{take_id}.mp4", "d1", clips=rows)


@pytest.mark.parametrize(
    ("person", "start_s", "partner", "problem"),
    [
        (1, 1.0, "other__c009", "is not a clip of the same take"),
        (0, 1.0, "t__c000", "is the same person"),
        (1, 9.0, "t__c000", "do not overlap in time"),
    ],
)
def test_the_store_refuses_a_partner_that_breaks_the_rule(
    tmp_path: Path, person: int, start_s: float, partner: str, problem: str
) -> None:
    a = person_clip("t__c000", 0, 0.0, 4.0, role=SPEAKING)
    b = replace(person_clip("t__c001", person, start_s, 4.0, role=2), partner_clip_id=partner)
    with pytest.raises(InputError, match=problem):
        check_partners([a, b], take_id="t")
    with pytest.raises(InputError, match=problem):
        store.write_take(tmp_path, record=_record("t", [a, b]), clips=[a, b])
    assert not store.take_dir(tmp_path, "t").exists()  # nothing written


def test_a_clip_without_partner_hears_no_partner() -> None:
    c = synthetic_clip(seconds=1.0)
    with pytest.raises(InputError, match="no partner"):
        replace(c, partner_speaking=np.ones(len(c.times), bool))
    with pytest.raises(InputError, match="partner_speaking must be"):
        replace(c, partner_speaking=np.zeros(3, bool))
