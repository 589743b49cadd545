"""Two people on rendered and real footage, built end to end (issue 32): a conversation in
turns keeps both people's clips with build.people = "all"; speech dubbed over two people who
do not speak makes nobody the speaker; Pose2Sim's two-person lab scene keeps a person."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturebank import footage
from gesturebank.clip import ROLES
from gesturebank.config import Config
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.pipeline import NOBODY_SPEAKS
from gesturebank.datasets.store import read_record
from gesturebank.extract.pipeline import extract_take
from gesturebank.synth.take import render_cache
from gesturebank.testing import conversation
from tests.datasets.test_real_footage import build

pytestmark = pytest.mark.media


def _longest_run_s(main_ids: np.ndarray, timestamps: np.ndarray) -> float:
    """Longest stretch, seconds, in which one person (id >= 0) is the main speaker."""
    best, start = 0.0, 0
    for i in range(1, len(main_ids) + 1):
        if i == len(main_ids) or main_ids[i] != main_ids[start]:
            if main_ids[start] >= 0:
                end = timestamps[i] if i < len(timestamps) else timestamps[-1]
                best = max(best, float(end - timestamps[start]))
            start = i
    return best


def test_with_people_all_both_people_of_a_conversation_keep_clips(
    samples: Path, tmp_path: Path
) -> None:
    talk = conversation.turn_taking(samples, render_cache(samples))
    out = build({"talk": talk.video}, tmp_path, build={"people": "all"})
    ds = open_dataset(out)
    accepted = ds.clips("accepted")
    record = read_record(out, accepted[0].take.take_id)
    assert record is not None
    summary = record.tracking["people"]  # what a .people.toml names a person by
    assert sorted(summary) == sorted(str(p) for p in {r.clip.person for r in accepted})
    assert all(0 <= v["at"][0] <= 1 and v["seen_s"] > 5 for v in summary.values())
    people = {row.clip.person for row in accepted}
    assert len(people) == 2, [(r.clip.person, r.clip.qc_reasons) for r in ds.rows()]
    for row in accepted:
        clip = ds.load(row.clip.clip_id)
        assert clip.person == row.clip.person
        assert clip.role.dtype == np.int8 and set(np.unique(clip.role)) <= set(range(len(ROLES)))
        assert row.clip.speaking_fraction == pytest.approx(clip.speaking_fraction)


def test_speech_dubbed_over_two_people_makes_nobody_the_speaker(
    samples: Path, tmp_path: Path
) -> None:
    dub = conversation.dubbed(samples, render_cache(samples))
    ext = extract_take(dub.video, Config())
    assert (ext.multi.present.sum(axis=1) >= 2).mean() > 0.9  # both are found
    longest = _longest_run_s(ext.tracked.report.main_ids, ext.multi.timestamps)
    print(f"\ndubbed two-person take: longest main speaker {longest:.2f} s")
    assert longest <= 1.0
    ds = open_dataset(build({"dub": dub.video}, tmp_path))
    assert not ds.clips("accepted")
    assert {r for row in ds.rows() for r in row.clip.qc_reasons} == {NOBODY_SPEAKS}


def test_pose2sim_two_person_scene_keeps_the_person_facing_the_camera(
    samples: Path, tmp_path: Path
) -> None:
    """Demo_MultiPerson cam04: the woman faces the camera, the man has his back to it."""
    recipe = footage.Recipe((footage.MULTI_CAM,), (5.0,))
    out = samples.parent / "footage" / "multi5"
    out.mkdir(parents=True, exist_ok=True)
    video = out / "multi.mp4"
    footage.make_take(recipe, samples=samples, out=video)
    ds = open_dataset(build({"multi": video}, tmp_path))
    assert ds.clips("accepted"), [r.clip.qc_reasons for r in ds.rows()]
