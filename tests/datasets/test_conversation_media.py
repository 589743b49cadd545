"""Two people on rendered and real footage, built end to end (issue 32): a conversation in
turns keeps both people's clips with build.people = "all", paired, split without dividing a
pair, and a listener model trains and is scored per role on them; speech dubbed over two people
who do not speak makes nobody the speaker; Pose2Sim's two-person lab scene keeps a person."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from gesturebank import footage
from gesturebank.app.extract import extract_take
from gesturebank.app.take import NOBODY_SPEAKS
from gesturebank.cli import app
from gesturebank.clip import ROLES
from gesturebank.config import Config
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.store import read_record
from gesturebank.extract import roles as R
from gesturebank.synth.take import render_cache
from gesturebank.testing import conversation
from tests.datasets.test_real_footage import build

pytestmark = pytest.mark.media

# The 11 s take cut into clips of at most 2.5 s (5 per person, so 5 pairs) and split 40/30/30 %:
# the dyadic split has pairs in each of train, validation and test.
PEOPLE_ALL = {
    "build": {"people": "all"},
    "clips": {"min_s": 2.0, "max_s": 2.5},
    "splits": {"dyadic_fractions": (0.4, 0.3, 0.3)},
}
GUARD_S = 0.5  # frames this close to a turn change are not judged (issue 32)
# a listener BLSTM small enough to train in seconds (tests/train/test_listener.py)
QUICK_TOML = """
[train.blstm]
layers = 1
units = 8
receptive = 9
span = 3

[train.eval]
fgd_epochs = 2
"""


@pytest.fixture(scope="module")
def people_all(samples: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The turn-taking take built with build.people = "all" (rendered and extracted once: both
    are cached)."""
    talk = conversation.turn_taking(samples, render_cache(samples))
    return build({"talk": talk.video}, tmp_path_factory.mktemp("talk"), **PEOPLE_ALL)


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


def test_with_people_all_both_people_of_a_conversation_keep_clips(people_all: Path) -> None:
    out = people_all
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


def test_on_the_rendered_conversation_the_roles_and_the_main_speaker_follow_the_turns(
    samples: Path,
) -> None:
    """Issue 32's acceptance on the rendered take, mouths measured by the face landmark model:
    each person's role track matches the turns on ≥ 90 % of frames (0.5 s around each turn change
    left out), and the main speaker switches with the turns by person id. Measured: 100 % and
    97 %; the main speaker right on 100 % of judged frames."""
    talk = conversation.turn_taking(samples, render_cache(samples))
    ext = extract_take(talk.video, Config())
    roles = ext.tracked.roles
    assert roles is not None
    t = ext.multi.timestamps
    nose_x = ext.multi.keypoints[:, :, 0, 0]
    ids = [int(k) for k in roles.track_ids]
    at_x = {k: float(np.nanmean(np.where(ext.tracked.ids == k, nose_x, np.nan))) for k in ids}
    assert len(ids) == 2, at_x
    person = sorted(ids, key=at_x.__getitem__)  # figure 0 stands on the left
    who = talk.speaker_at(t)
    near_change = np.zeros(len(t), bool)
    for a, b, _ in talk.turns:
        near_change |= (np.abs(t - a) < GUARD_S) | (np.abs(t - b) < GUARD_S)
    judged = ~near_change & (who >= 0)
    for figure, track in enumerate(person):
        want = np.where(who[judged] == figure, R.SPEAKING, R.LISTENING)
        match = float(np.mean(roles.role[judged, roles.column(track)] == want))
        print(f"\nfigure {figure}: role matches the turns on {match:.1%} of judged frames")
        assert match >= 0.9
    main = ext.tracked.report.main_ids
    assert np.mean(main[judged] == np.array(person)[who[judged]]) >= 0.9
    choices = [(c.main_id, c.reason) for c in ext.tracked.report.choices]
    assert choices == [(person[w], "speaks") for _, _, w in talk.turns]  # one per turn


def _speaking_at(times_s: np.ndarray, partner_times_s: np.ndarray, role: np.ndarray) -> np.ndarray:
    """The partner's role is "speaking" at its frame nearest each of `times_s` (within half a
    frame; False outside the partner's clip)."""
    hop = float(np.median(np.diff(partner_times_s)))
    nearest = np.abs(times_s[:, None] - partner_times_s[None, :]).argmin(axis=1)
    near = np.abs(partner_times_s[nearest] - times_s) <= hop / 2
    return near & (role[nearest] == ROLES.index("speaking"))


def test_with_people_all_the_two_people_are_paired_and_the_dyadic_split_keeps_pairs(
    people_all: Path,
) -> None:
    ds = open_dataset(people_all)
    rows = {r.clip.clip_id: r.clip for r in ds.rows() if r.clip.kind == "clip"}
    paired = {i: c.partner_clip_id for i, c in rows.items() if c.partner_clip_id}
    assert len(paired) >= 4, {i: (c.person, c.qc_reasons) for i, c in rows.items()}
    for clip_id, partner_id in paired.items():
        assert paired.get(partner_id) == clip_id  # both ways: the two people start together
        assert rows[clip_id].person != rows[partner_id].person
        own, other = ds.load_arrays(clip_id), ds.load_arrays(partner_id)
        assert str(own["partner_clip_id"]) == partner_id  # the npz agrees with the manifest
        expected = _speaking_at(
            rows[clip_id].start_s + own["times"].astype(np.float64),
            rows[partner_id].start_s + other["times"].astype(np.float64),
            other["role"],
        )
        np.testing.assert_array_equal(own["partner_speaking"], expected)
    split = json.loads((people_all / "splits" / "dyadic.json").read_text())
    part_of = {i: part for part in ("train", "val", "test") for i in split[part]}
    accepted = {r.clip.clip_id for r in ds.clips("accepted")}
    assert set(part_of) == accepted
    assert all(split[part] for part in ("train", "val", "test")), split
    for clip_id in accepted & set(paired):
        if paired[clip_id] in accepted:
            assert part_of[clip_id] == part_of[paired[clip_id]]  # a pair is never divided


def test_a_listener_blstm_trains_on_the_conversation_and_is_scored_per_role(
    people_all: Path, tmp_path: Path
) -> None:
    """`gesturebank train <ds> --variant dyadic --target listener --model blstm`, then
    `gesturebank evaluate` on its test part."""
    config = tmp_path / "quick.toml"
    config.write_text(QUICK_TOML)
    model = tmp_path / "listener"
    runner = CliRunner()
    args = ["train", str(people_all), "--model", "blstm", "--variant", "dyadic"]
    args += ["--target", "listener", "--epochs", "1", "--out", str(model), "-c", str(config)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    info = json.loads((model / "model.json").read_text())
    assert (info["target"], info["variant"]) == ("listener", "dyadic")
    result = runner.invoke(app, ["evaluate", str(model)])
    assert result.exit_code == 0, result.output
    roles = json.loads((model / "metrics.json").read_text())["per_role"]
    assert sorted(roles) == sorted(ROLES)
    assert roles["listening"]["known"] > 0 and np.isfinite(roles["listening"]["L"])
    assert roles["speaking"]["known"] == 0  # a listener model is scored where it listens


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
