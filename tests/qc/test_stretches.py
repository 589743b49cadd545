"""Issue 41: a check of scope "stretch" cuts the clip around the stretch that fails it (pieces of
at least clips.min_s, each judged again); a check of scope "take" rejects the clip whole. Issue
42: one table of checks, and a check added from outside with its entry and metric function."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from pydantic import Field

from gesturebank.clip import Clip
from gesturebank.config import Config, QCConfig
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.listing import list_clips
from gesturebank.datasets.partners import LISTENING, SPEAKING, pair_clips
from gesturebank.datasets.refresh import refresh
from gesturebank.qc import table
from gesturebank.qc.checks import absolute_reasons, failures
from gesturebank.qc.metrics import clip_metrics
from gesturebank.qc.stretches import Judged, best_pieces, judge, piece, signal_of
from gesturebank.qc.table import Signal
from gesturebank.report import write_dashboard
from gesturebank.robot import pepper
from gesturebank.skeletons import COCO17
from gesturebank.testing.clips import synthetic_clip, write_dataset
from gesturebank.testing.dyads import with_person

PROFILE = pepper.load_profile()
MIN_S = 3.0


def _judge(clip: Clip, qc: QCConfig) -> list[Judged]:
    return judge(
        clip,
        measure=lambda c: clip_metrics(c, profile=PROFILE, qc=qc),
        config=qc,
        profile=PROFILE,
        min_s=MIN_S,
    )


def _kept_s(outcomes: list[Judged]) -> float:
    return sum(j.end_s - j.start_s for j in outcomes if j.clip is not None and not j.reasons)


def _with_spike(clip: Clip, frame: int) -> Clip:
    """The right wrist thrown 3 shoulder widths away in the 2D for one frame (the 3D, lifted
    and repaired, did not follow: its bones stay rigid)."""
    kp = np.array(clip.pose2d.keypoints, copy=True)
    w = COCO17.index["right_wrist"]
    ls, rs = COCO17.index["left_shoulder"], COCO17.index["right_shoulder"]
    kp[frame, w, 0] += 3 * np.linalg.norm(kp[frame, ls, :2] - kp[frame, rs, :2])
    return replace(clip, pose2d=replace(clip.pose2d, keypoints=kp))


def test_the_table_holds_every_threshold_once_and_names_config_fields() -> None:
    names = [c.name for c in table.CHECKS]
    assert len(names) == len(set(names))
    for check in table.CHECKS:
        assert check.field is None or check.field in QCConfig.model_fields, check.name
        assert check.unit in table.UNITS, check.name
        assert (check.scope == "stretch") == (signal_of(check) is not None), check.name
    stretch = {c.name for c in table.CHECKS if c.scope == "stretch"}
    # the list: frozen at a limit, sideways or facing away, depth uncertain, jitter and
    # glitch runs, low visibility, no speech
    assert {"frozen_at_limit", "sideways", "facing_away", "depth_uncertain", "jitter"} <= stretch
    assert {"spike", "swaps", "head_unseen", "arms_unseen", "no_speech"} <= stretch
    take = {c.name for c in table.CHECKS if c.scope == "take"}
    assert {"still_picture", "bones_drift", "frozen_pose", "audio_mismatch", "static"} <= take


def test_a_one_frame_glitch_costs_its_stretch_not_the_clip() -> None:
    clip = _with_spike(synthetic_clip(seconds=12.0, seed=3), frame=180)
    qc = QCConfig()
    reasons = absolute_reasons(clip_metrics(clip, profile=PROFILE, qc=qc), qc)
    assert any("keypoint jumps" in r for r in reasons)
    old = _judge(clip, qc.model_copy(update={"stretch_rounds": 0}))
    assert len(old) == 1 and old[0].reasons  # the old rule: rejected whole
    outcomes = _judge(clip, qc)
    dropped = [j for j in outcomes if j.clip is None]
    assert len(dropped) == 1 and dropped[0].reasons[0].startswith("cut: keypoint jumps")
    assert 6.0 - 0.05 <= dropped[0].start_s + 0.2 <= 6.0 + 0.05  # the glitch's frame, 0.2 s margin
    assert dropped[0].end_s - dropped[0].start_s < 0.6
    pieces = [j for j in outcomes if j.clip is not None]
    assert len(pieces) == 2 and all(not j.reasons for j in pieces)
    assert _kept_s(outcomes) > 11.0
    for j in pieces:  # a piece is a clip: judged again, on its own clock
        assert j.clip is not None
        assert j.clip.times[0] == 0.0 and len(j.clip.timestamps) == len(j.clip.pose2d)


def test_a_sideways_stretch_is_cut_until_the_rest_passes() -> None:
    clip = synthetic_clip(seconds=20.0, seed=1)
    kp = np.array(clip.pose2d.keypoints, copy=True)
    nose, ls = COCO17.index["nose"], COCO17.index["left_shoulder"]
    side = (clip.timestamps >= 8.0) & (clip.timestamps < 12.0)  # 4 s of 20 seen from the side
    kp[side, nose, :2] = kp[side, ls, :2] + (kp[side, ls, :2] - kp[side, nose, :2]) * 0.1
    clip = replace(clip, pose2d=replace(clip.pose2d, keypoints=kp))
    qc = QCConfig(max_sideways_fraction=0.1)  # 20 % fails it
    metrics = clip_metrics(clip, profile=PROFILE, qc=qc)
    assert metrics.sideways_fraction == pytest.approx(0.2, abs=0.02)
    outcomes = _judge(clip, qc)
    kept = [j for j in outcomes if j.clip is not None and not j.reasons]
    assert kept, outcomes
    for j in kept:
        assert j.metrics is not None and j.metrics.sideways_fraction <= 0.1
    cut = [j for j in outcomes if j.clip is None and j.reasons[0].startswith("cut: seen from")]
    assert cut and all(7.5 <= j.start_s and j.end_s <= 12.5 for j in cut)
    # the least footage that passes: about the side view's excess, not the whole 4 s, is cut
    assert _kept_s(outcomes) >= 15.0


def test_a_whole_take_fault_still_rejects_the_clip_whole() -> None:
    clip = _with_spike(synthetic_clip(seconds=12.0, seed=3), frame=180)
    still = replace(clip, change=np.zeros_like(clip.change))  # a still picture, and a glitch
    qc = QCConfig()
    outcomes = _judge(still, qc)
    assert len(outcomes) == 1 and outcomes[0].clip is still
    assert any(r.startswith("still picture") for r in outcomes[0].reasons)


def test_a_piece_keeps_the_clip_arrays_of_its_frames() -> None:
    clip = synthetic_clip(seconds=6.0, seed=2)
    part = piece(clip, 30, stop=120, clip_id="x__c001")
    assert part.start_s == pytest.approx(clip.start_s + 1.0, abs=0.011)
    i0 = int(np.searchsorted(clip.times, clip.timestamps[30] - 1e-9))
    np.testing.assert_array_equal(part.angles, clip.angles[i0 : i0 + len(part.times)])
    np.testing.assert_array_equal(part.pose2d.keypoints, clip.pose2d.keypoints[30:120])
    assert part.timestamps[0] == pytest.approx(clip.timestamps[30] - clip.times[i0])


class ToyQC(QCConfig):
    """A plug-in's config: its check's threshold beside the built-in ones."""

    max_wrist_above_nose: float = Field(0.2, ge=0, le=1)


def _wrist_above(clip: Clip) -> np.ndarray:
    xy = np.asarray(clip.pose2d.to_coco17().keypoints)[..., 1]
    return np.asarray(xy[:, COCO17.index["right_wrist"]] < xy[:, COCO17.index["nose"]])


def test_a_check_added_from_outside_is_judged_cut_and_listed() -> None:
    """Adding a check is one entry plus its metric function (and its signal, for a stretch)."""
    toy = table.Check(
        name="wrist_above_nose",
        metric="wrist_above_nose_fraction",
        field="max_wrist_above_nose",
        side="max",
        unit="share",
        scope="stretch",
        label="right wrist above the nose",
        reason="right wrist above the nose in {v:.0%} of frames (max {lim:.0%})",
        measure=lambda clip, qc, profile: float(np.mean(_wrist_above(clip))),
        stretch=lambda clip, qc, profile: Signal(
            _wrist_above(clip).astype(float), np.ones(len(clip.timestamps)), 0.2
        ),
    )
    clip = synthetic_clip(seconds=15.0, seed=4)
    kp = np.array(clip.pose2d.keypoints, copy=True)
    up = (clip.timestamps >= 5.0) & (clip.timestamps < 10.0)
    kp[up, COCO17.index["right_wrist"], 1] = kp[up, COCO17.index["nose"], 1] - 50
    clip = replace(clip, pose2d=replace(clip.pose2d, keypoints=kp))
    qc = ToyQC()
    table.register(toy)
    try:
        metrics = clip_metrics(clip, profile=PROFILE, qc=qc)
        assert metrics.value("wrist_above_nose_fraction") == pytest.approx(1 / 3, abs=0.02)
        assert metrics.to_dict()["wrist_above_nose_fraction"] == pytest.approx(1 / 3, abs=0.02)
        failed = failures(metrics, qc)
        assert [f.check for f in failed] == [toy]
        outcomes = _judge(clip, qc)
        cut = [j for j in outcomes if j.clip is None]
        assert cut and cut[0].reasons[0].startswith("cut: right wrist above the nose")
        assert all(not j.reasons for j in outcomes if j.clip is not None)
        assert _kept_s(outcomes) >= 9.0
    finally:
        table.unregister("wrist_above_nose")
    assert "wrist_above_nose" not in {c.name for c in table.CHECKS}
    assert failures(clip_metrics(clip, profile=PROFILE, qc=qc), qc) == []


def test_stretches_cut_when_rejudging(tmp_path: Path) -> None:
    """`gesturebank qc OUT` cuts as the build does: a clip stored whole (judged with
    qc.stretch_rounds = 0) with a one-frame glitch becomes two accepted pieces and a dropped
    stretch, which `clips --status rejected` lists. A second person beside it was its partner:
    it names one of the pieces after the cut (the build's pairing), and each piece names it, in
    the records and the files."""
    clips = {
        f"s{i}_take": [synthetic_clip(seconds=4.0, seed=10 + i, clip_id=f"s{i}_take__c000")]
        for i in range(3)
    }
    glitch = replace(_with_spike(synthetic_clip(seconds=12.0, seed=3), 180), clip_id="g_take__c000")
    other = synthetic_clip(seconds=12.0, seed=4, clip_id="g_take__c001")
    speaker = with_person(glitch, person=0, role=np.full(len(glitch.times), SPEAKING, np.int8))
    listener = with_person(other, person=1, role=np.full(len(other.times), LISTENING, np.int8))
    whole = Config.model_validate({"qc": {"stretch_rounds": 0}})
    takes = {**clips, "g_take": pair_clips([speaker, listener])}
    out = write_dataset(tmp_path, takes, config=whole, in_turn=False)
    assert open_dataset(out).clip_ids("rejected") == ["g_take__c000"]
    refresh(out, Config())
    ds = open_dataset(out)
    assert "g_take__c000" not in ds.clip_ids(None)
    pieces = [c for c in ds.clip_ids("accepted") if c.startswith("g_take__c000")]
    assert pieces == ["g_take__c000p0", "g_take__c000p1"]
    partners = {r.clip.clip_id: r.clip.partner_clip_id for r in ds.rows() if r.clip.kind == "clip"}
    assert partners["g_take__c001"] in pieces
    assert ds.load("g_take__c001").partner_clip_id == partners["g_take__c001"]
    for kept in pieces:
        assert partners[kept] == ds.load(kept).partner_clip_id == "g_take__c001"
    assert sum(ds.load(c).duration_s for c in pieces) > 11.0
    assert not (out / "takes" / "g_take" / "g_take__c000.npz").exists()
    rejected = list_clips(ds, status="rejected")
    assert [r.clip_id for r in rejected] == ["g_take__c000s0"]
    assert rejected[0].reasons[0].startswith("cut: keypoint jumps")
    assert 5.7 < rejected[0].start_s < rejected[0].end_s < 6.3
    refresh(out, Config())  # judging again changes nothing
    assert open_dataset(out).clip_ids(None) == ds.clip_ids(None)
    write_dashboard(out)  # the take's timeline shows the stretch cut out, with its reason
    page = (out / "qc" / "takes" / "g_take.html").read_text(encoding="utf-8")
    data = json.loads(page.split("id='data'>", 1)[1].split("</script>", 1)[0])
    cut = [s for s in data["timeline"]["segments"] if s["kind"] == "cut"]
    assert [s["id"] for s in cut] == ["g_take__c000s0"]
    assert cut[0]["reasons"][0].startswith("cut: keypoint jumps")


def test_the_pieces_kept_are_the_most_seconds_that_pass() -> None:
    """1 s frames: 4 bad frames in the middle of 12 with a limit of 25 % (excess 0.75 per bad
    frame, −0.25 per good one) and pieces of 3 s at least: keeping 3 good frames per bad one
    is allowed, so the best is frames 0–7 (1 bad) or similar, not the good frames alone."""
    bad = np.zeros(12)
    bad[5:9] = 1.0
    starts = np.arange(12.0)
    pieces = best_pieces(
        excesses=[bad - 0.25], forbidden=np.zeros(12, bool), starts=starts, ends=starts + 1,
        min_s=3.0,
    )  # fmt: skip
    kept = sum(b - a for a, b in pieces)
    assert all(bad[a:b].sum() <= 0.25 * (b - a) for a, b in pieces)
    assert all(b - a >= 3 for a, b in pieces)
    assert kept == 10  # e.g. [0, 6) with one bad frame... and [8, 12) with one
    forbidden = np.zeros(12, bool)
    forbidden[5] = True  # a glitch: no piece may hold it
    pieces = best_pieces(
        excesses=[], forbidden=forbidden, starts=starts, ends=starts + 1, min_s=3.0
    )
    assert pieces == [(0, 5), (6, 12)]


def test_motion_capture_has_no_view_to_judge() -> None:
    """Issue 41: the view limits were set by what a view costs a lift; measured 3D has no
    camera, so a mocap clip turned sideways is not judged by them (a video's still is)."""
    clip = synthetic_clip(seconds=6.0, seed=5)
    kp = np.array(clip.pose2d.keypoints, copy=True)
    nose, ls = COCO17.index["nose"], COCO17.index["left_shoulder"]
    kp[:, nose, :2] = kp[:, ls, :2] + (kp[:, ls, :2] - kp[:, nose, :2]) * 0.1  # all from the side
    side = replace(clip, pose2d=replace(clip.pose2d, keypoints=kp))
    video = clip_metrics(side, profile=PROFILE, qc=QCConfig())
    assert video.sideways_fraction > 0.9
    mocap = replace(side, pose3d=replace(side.pose3d, meta={"source": "bvh"}))
    measured = clip_metrics(mocap, profile=PROFILE, qc=QCConfig())
    assert np.isnan(measured.sideways_fraction) and np.isnan(measured.facing_away_fraction)
    assert not [f for f in failures(measured, QCConfig()) if f.check and f.check.name == "sideways"]
