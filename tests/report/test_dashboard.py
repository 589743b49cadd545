"""The QC dashboard of a clip dataset: what the pages say, that they stay small and unchanged
when the dataset is, and that they load and draw offline in real headless Chromium."""

from __future__ import annotations

import json
import re
import shutil
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from gesturebank.app.build import BuildSummary, dashboard_after_build
from gesturebank.clip import HEAD_SOURCES, ROLES, Clip
from gesturebank.config import Config, QCConfig
from gesturebank.datasets import store
from gesturebank.datasets.refresh import refresh
from gesturebank.qc.checks import THRESHOLDS, absolute_reasons, fails
from gesturebank.qc.clip_metrics import ClipMetrics
from gesturebank.report import write_dashboard
from gesturebank.report.data import head_runs, reason_kind, role_runs
from gesturebank.robot.retarget import pepper_angles
from gesturebank.skeletons import COCO17, COCO17_BONES
from gesturebank.testing.browser import CHROMIUM, Browser, Tab
from gesturebank.testing.clips import clip_from_angles, synthetic_clip, write_dataset

SECONDS = 8.0
# The mixed take: a kept clip, a dropped span (the speaker left), a rejected clip (arms swapped).
GAP = (SECONDS, SECONDS + 4.0)
PREVIEW_TIMES = (2.0, 9.5, 14.0, 18.0)
STRIP_FRAME = (320, 180)  # px of one preview frame (the synthetic video is 1280 × 720)


def _swap_arms(clip: Clip, frames: slice) -> Clip:
    """The clip as if the detector had exchanged the left and right elbows and wrists in
    `frames`: the swapped 3D pose retargeted, and a clip made of those angles."""
    joints = clip.pose3d.joints.copy()
    for part in ("elbow", "wrist"):
        left, right = COCO17.index[f"left_{part}"], COCO17.index[f"right_{part}"]
        joints[frames, left] = clip.pose3d.joints[frames, right]
        joints[frames, right] = clip.pose3d.joints[frames, left]
    angles = pepper_angles(replace(clip.pose3d, joints=joints))
    return clip_from_angles(angles, clip.timestamps, clip_id=clip.clip_id)


def _unseen(clip: Clip, frames: slice) -> Clip:
    """The clip with nobody seen in `frames` (NaN angles → unseen keypoints, masked angles)."""
    angles = clip.raw_angles.copy()
    angles[frames] = np.nan
    return clip_from_angles(angles, clip.timestamps, clip_id=clip.clip_id)


def _clean(take: str, k: int, seed: int) -> Clip:
    return synthetic_clip(seconds=SECONDS, seed=seed, clip_id=f"{take}__c{k:03d}")


def _pause(clip: Clip) -> Clip:
    """The clip with no speech heard from 1.0 to 1.5 s of its clock (a pause)."""
    speech = np.asarray(clip.speech, bool).copy()
    speech[(clip.times >= 1.0) & (clip.times < 1.5)] = False
    return replace(clip, speech=speech)


DOUBT = (2.0, 3.0, 0.6)  # s1_clean's first clip: depth confidence 0.6 from 2 to 3 s of its clock


def _doubt(clip: Clip) -> Clip:
    """The clip with its depth signs in doubt (confidence DOUBT[2]) from DOUBT[0] to DOUBT[1]."""
    confidence = np.asarray(clip.depth_confidence, np.float32).copy()
    confidence[(clip.timestamps >= DOUBT[0]) & (clip.timestamps < DOUBT[1])] = DOUBT[2]
    return replace(clip, depth_confidence=confidence)


def _preview_jpeg(clips: list[Clip]) -> bytes:
    """A strip of 'video frames' with the speaker drawn as a grey stick figure where the clips
    place them, so that the page's skeletons must land on the figures."""
    w, h = STRIP_FRAME
    strip = np.full((h, w * len(PREVIEW_TIMES), 3), (60, 90, 40), np.uint8)
    for i, t in enumerate(PREVIEW_TIMES):
        cv2.putText(strip, f"frame {i + 1}", (i * w + 8, h - 10), 0, 0.5, (255, 255, 255), 1)
        clip = next((c for c in clips if c.start_s <= t < c.start_s + c.duration_s), None)
        if clip is None:
            continue
        k = int(np.argmin(np.abs(clip.pose2d.timestamps + clip.start_s - t)))
        xy = clip.pose2d.xy[k] * (w / 1280)
        for a, b in COCO17_BONES:
            p, q = xy[COCO17.index[a]], xy[COCO17.index[b]]
            if np.isfinite(p).all() and np.isfinite(q).all():
                p0, q0 = (int(i * w + p[0]), int(p[1])), (int(i * w + q[0]), int(q[1]))
                cv2.line(strip, p0, q0, (200, 200, 200), 7)
    ok, jpeg = cv2.imencode(".jpg", strip, [cv2.IMWRITE_JPEG_QUALITY, 80])
    assert ok
    return jpeg.tobytes()


def _tracking() -> dict[str, Any]:
    """A main-speaker report: two shots, a runner-up in the first."""
    scores = {"size": 0.8, "centrality": 0.9, "speech": 0.6, "total": 2.3}
    return {
        "choices": [
            {
                "start_s": 0.0,
                "end_s": 10.0,
                "shot": 0,
                "reason": "shot",
                "main_id": 1,
                "runner_up": 4,
                "scores": {"1": scores, "4": {**scores, "centrality": 0.2, "total": 1.6}},
            },
            {
                "start_s": 10.0,
                "end_s": 2 * SECONDS + 4.0,
                "shot": 1,
                "reason": "shot",
                "main_id": 2,
                "runner_up": None,
                "scores": {"2": scores},
            },
        ]
    }


def _mix_take(out: Path, clips: list[Clip]) -> None:
    """Turn the take of `clips` (written back to back) into: clip 0, a dropped span, clip 1;
    with a preview strip and a tracking report."""
    record = store.read_record(out, "s4_mixed")
    assert record is not None
    first, second = record.data_clips
    span = store.ClipRecord("s4_mixed__s000", "span", *GAP, "rejected", ("main speaker absent",))
    moved = replace(second, start_s=GAP[1], end_s=GAP[1] + second.duration_s)
    record = replace(
        record,
        clips=(first, span, moved),
        seconds=moved.end_s,
        visible_s=record.visible_s,
        preview_times=PREVIEW_TIMES,
        tracking=_tracking(),
    )
    (store.take_dir(out, "s4_mixed") / store.PREVIEW).write_bytes(_preview_jpeg(clips))
    store.write_record(out, record)


# The whole-clip rules on (opt-in since issue 32), so that an unseen head is a threshold shown;
# clips judged whole (no stretch cut, issue 41), so that they stay rejected clips to be shown
WHOLE = Config.model_validate(
    {
        "qc": {
            "max_head_unknown_fraction": 0.5,
            "max_arms_unknown_fraction": 0.5,
            "stretch_rounds": 0,
        }
    }
)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("dashboard")
    masked = _unseen(_clean("s2_masked", 0, 20), slice(90, 120))  # 1 s unseen
    repaired = np.zeros_like(masked.repaired)
    repaired[30:36, COCO17.index["left_wrist"]] = True
    mixed = [
        _clean("s4_mixed", 0, 40),
        replace(_swap_arms(_clean("s4_mixed", 1, 41), slice(60, 90)), start_s=GAP[1]),
    ]
    takes = {
        "s1_clean": [_doubt(_pause(_clean("s1_clean", 0, 10))), _clean("s1_clean", 1, 11)],
        "s2_masked": [replace(masked, repaired=repaired)],
        "s3_unseen": [_unseen(_clean("s3_unseen", 0, 30), slice(20, None))],
        "s4_mixed": mixed,
        "s6_clean": [_clean("s6_clean", 0, 60), _clean("s6_clean", 1, 61)],
    }
    write_dataset(out, takes, config=WHOLE)
    _mix_take(out, mixed)
    failed = store.TakeRecord(
        "s5_failed", "s5", "s5_failed.mp4", "x", failed="no audio track", seconds=3.0
    )
    store.write_record(out, failed)
    refresh(out, WHOLE)
    write_dashboard(out)
    return out


def _page(dataset: Path, take: str) -> str:
    return (dataset / "qc" / "takes" / f"{take}.html").read_text(encoding="utf-8")


def _data(page: str) -> dict[str, Any]:
    found = re.search(r"<script type='application/json' id='data'>(.*?)</script>", page, re.S)
    assert found
    return json.loads(found.group(1))


def _table_rows(page: str, table_id: str) -> list[list[str]]:
    """Text of each body row's cells."""
    table = page.split(f"id='{table_id}'>", 1)[1].split("</table>", 1)[0]
    body = table.split("<tbody>", 1)[1]
    rows = re.findall(r"<tr>(.*?)</tr>", body, re.S)
    return [
        [re.sub(r"<[^>]+>", "", c) for c in re.findall(r"<td[^>]*>(.*?)</td>", r)] for r in rows
    ]


def _undelta(steps: list[int | None], unit: float) -> list[float | None]:
    v, out = 0, []
    for s in steps:
        if s is not None:
            v += s
        out.append(None if s is None else v * unit)
    return out


# --------------------------------------------------------------------------------------------------
# What the pages say


def test_the_corrupted_clips_are_rejected(dataset: Path) -> None:
    """The premise of the other tests: the dataset has kept, rejected and dropped time."""
    unseen = store.read_record(dataset, "s3_unseen")
    mixed = store.read_record(dataset, "s4_mixed")
    assert unseen is not None and mixed is not None
    assert unseen.clips[0].qc_status == "rejected"
    assert any("head unseen" in r for r in unseen.clips[0].qc_reasons)
    assert [c.kind for c in mixed.clips] == ["clip", "span", "clip"]
    assert [c.qc_status for c in mixed.clips] == ["accepted", "rejected", "rejected"]
    assert any("raw jerk" in r for r in mixed.clips[2].qc_reasons)


def test_index_lists_every_take_by_usable_seconds(dataset: Path) -> None:
    index = (dataset / "qc" / "index.html").read_text(encoding="utf-8")
    rows = _table_rows(index, "takes")
    records = {r.take_id: r for r in store.take_records(dataset)}
    assert sorted(row[0] for row in rows) == sorted(records)
    usable = [float(row[4]) for row in rows]
    assert usable == sorted(usable, reverse=True)
    for row in rows:
        assert float(row[4]) == pytest.approx(records[row[0]].usable_s, abs=0.05)
    assert "href='takes/s4_mixed.html'" in index
    mixed = next(row for row in rows if row[0] == "s4_mixed")
    assert mixed[3] == "1/2" and "main speaker absent (4.0 s)" in mixed[7]
    failed = next(row for row in rows if row[0] == "s5_failed")
    assert failed[2] == "failed" and "no audio track" in failed[7]
    total = sum(r.usable_s for r in records.values())
    assert f"<td id='sum-0'>{total:.1f}</td>" in index


def test_index_sums_the_reasons(dataset: Path) -> None:
    index = (dataset / "qc" / "index.html").read_text(encoding="utf-8")
    reasons = {row[0]: row for row in _table_rows(index, "reasons")}
    assert float(reasons["main speaker absent"][2]) == pytest.approx(4.0)
    assert "head unseen in …% of the clip" in reasons
    assert reasons["no audio track"][1] == "1 failed"
    data = _data(index)
    assert len(data["clips"]) == 8 and len(data["joint_raw"]) == 11
    assert reason_kind("3D bone length varies by 31% (max 20%)") == "3D bone length varies by …%"


def test_take_page_timeline_shows_kept_rejected_and_dropped(dataset: Path) -> None:
    page = _page(dataset, "s4_mixed")
    line = _data(page)["timeline"]
    kinds = [(s["kind"], s["t0"], s["t1"]) for s in line["segments"]]
    assert [k for k, _, _ in kinds] == ["kept", "dropped", "rejected"]
    assert kinds[1][1:] == GAP
    assert line["segments"][1]["reasons"] == ["main speaker absent"]
    assert any("raw jerk" in r for r in line["segments"][2]["reasons"])
    assert line["cuts"] == [10.0]
    assert [s["label"] for s in line["speakers"]] == ["#1 (runner-up #4)", "#2"]
    assert "person 1 was chosen over person 4" in page  # the speaker row explained
    assert "runner-up #4 (total 1.6)" in line["speakers"][0]["tip"]
    segments = page.split("<ol class='segments'>")[1].split("</ol>")[0]
    assert "dropped</span> s4_mixed__s000: main speaker absent" in segments
    assert "raw jerk" in segments
    assert "id='speakers'" in page  # the scores per segment


def test_preview_frames_carry_the_skeleton_unless_dropped(dataset: Path) -> None:
    preview = _data(_page(dataset, "s4_mixed"))["preview"]
    assert preview["w"] == 4 * STRIP_FRAME[0] and preview["src"].startswith("data:image/jpeg")
    frames = preview["frames"]
    assert [f["points"] is None for f in frames] == [False, True, False, False]
    assert frames[1]["note"] == "dropped: main speaker absent"
    nose = frames[2]["points"][COCO17.index["nose"]]
    assert 2 * STRIP_FRAME[0] < nose[0] < 3 * STRIP_FRAME[0]  # on the third frame
    assert "No preview strip" in _page(dataset, "s1_clean")


def test_clip_plots_carry_masked_spans_and_repaired_frames(dataset: Path) -> None:
    page = _data(_page(dataset, "s2_masked"))
    (clip,) = page["clips"]
    assert len(clip["proc"]["v"]) == len(clip["raw"]["v"]) == len(page["joints"]) == 11
    arm = page["joints"].index("LElbowYaw")
    (masked,) = clip["masked"][arm]
    assert masked[0] == pytest.approx(3.0, abs=0.1) and masked[1] == pytest.approx(4.0, abs=0.1)
    (fixed,) = clip["repaired"][arm]  # the left wrist moves the left elbow's angles
    assert fixed == pytest.approx([1.0, 1.2], abs=0.01)
    assert clip["repaired"][page["joints"].index("RElbowYaw")] == []
    proc = _undelta(clip["proc"]["v"][arm], 0.1)
    times = [clip["proc"]["t0"] + i * clip["proc"]["dt"] for i in range(len(proc))]
    inside = [v for t, v in zip(times, proc, strict=True) if 3.2 < t < 3.8]
    assert inside and all(v is None for v in inside)  # unknown, not drawn
    assert len(proc) <= 25 * SECONDS + 1  # thinned for the page


def _metric_rows(page: str, clip_id: str) -> dict[str, tuple[bool, list[str]]]:
    """metric key → (row marked as failed, cell texts) of a clip's metrics table."""
    section = page.split(f"id='{clip_id}'>", 1)[1].split("</section>", 1)[0]
    table = section.split("<table class='metrics'>", 1)[1].split("</table>", 1)[0]
    rows = re.findall(r"<tr( class='fail')? data-metric='(\w+)'>(.*?)</tr>", table, re.S)
    return {
        key: (
            bool(fail),
            [re.sub(r"<[^>]+>", "", c) for c in re.findall(r"<td[^>]*>(.*?)</td>", r)],
        )
        for fail, key, r in rows
    }


def test_each_metric_is_shown_beside_its_threshold_and_the_failed_one_marked(
    dataset: Path,
) -> None:
    unseen = _metric_rows(_page(dataset, "s3_unseen"), "s3_unseen__c000")
    fail, (label, value, limit, check) = unseen["head_unknown_fraction"]
    assert fail and label == "head unseen" and limit == "max 50 %" and check == "✗ over the max"
    assert float(value.split()[0]) > 50
    assert unseen["motion_range"][1][2] == "min 2.0°"  # the metric's own unit
    record = store.read_record(dataset, "s3_unseen")
    assert record is not None  # one marked row per reason the clip was rejected for
    assert sum(f for f, _ in unseen.values()) == len(record.clips[0].qc_reasons)
    mixed = _metric_rows(_page(dataset, "s4_mixed"), "s4_mixed__c001")
    fail, (_, _, limit, check) = mixed["jerk_raw"]
    assert fail and check == "✗ outlier" and "dataset median" in limit
    kept = _metric_rows(_page(dataset, "s4_mixed"), "s4_mixed__c000")
    assert not any(f for f, _ in kept.values()) and kept["people"][1][3] == "✓"
    labels = [cells[0] for _, cells in kept.values()]
    assert not [x for x in labels if "_" in x], labels  # no raw key leaks


def test_after_a_build_the_dashboard_is_written_or_says_why_not(
    dataset: Path, tmp_path: Path
) -> None:
    """build-dataset's last step: the index in the summary; a build that could not write its
    shared files gets no dashboard; one that cannot be written ends the build in one line."""
    summary = dashboard_after_build(BuildSummary(dataset))
    assert summary.dashboard == dataset / "qc" / "index.html" and not summary.error
    stopped = dashboard_after_build(BuildSummary(tmp_path, error="dataset.json: disk full"))
    assert stopped.dashboard is None and not (tmp_path / "qc").exists()
    blocked = tmp_path / "blocked"
    shutil.copytree(dataset, blocked)
    shutil.rmtree(blocked / "qc")
    (blocked / "qc").write_text("not a folder")
    failed = dashboard_after_build(BuildSummary(blocked))
    assert failed.dashboard is None and "cannot write" in failed.error
    assert "finished takes are kept" in failed.error and "\n" not in failed.error


def test_every_absolute_check_has_its_threshold_for_the_dashboard() -> None:
    """checks.THRESHOLDS (what the page shows) and absolute_reasons (what rejects) agree: a
    metric just past its limit gives exactly one reason and fails exactly its own check."""
    qc = QCConfig(  # the opt-in checks on
        max_jerk_raw=1e4,
        max_limit_fraction=0.6,
        max_head_unknown_fraction=0.5,
        max_arms_unknown_fraction=0.5,
    )
    for key, (field, side) in THRESHOLDS.items():
        limit = getattr(qc, field)
        past = limit * 1.5 + 1 if side == "max" else limit * 0.5
        assert len(absolute_reasons(ClipMetrics.from_dict({key: past}), qc)) == 1, key
        assert absolute_reasons(ClipMetrics.from_dict({key: limit}), qc) == [], key
        assert fails(key, past, config=qc) and not fails(key, limit, config=qc), key
    worst = {
        k: (getattr(qc, f) * 1.5 + 1 if s == "max" else 0.0) for k, (f, s) in THRESHOLDS.items()
    }
    assert len(absolute_reasons(ClipMetrics.from_dict(worst), qc)) == len(
        THRESHOLDS
    )  # no check missing from the table


def test_pages_are_small_and_fetch_nothing(dataset: Path) -> None:
    pages = list((dataset / "qc").rglob("*.html"))
    assert len(pages) == 1 + 6
    for page in pages:
        text = page.read_text(encoding="utf-8")
        assert page.stat().st_size < 300_000, page
        assert "http://" not in text and "https://" not in text, page
        assert "default-src 'none'" in text


def test_an_unchanged_dataset_rewrites_no_page(dataset: Path) -> None:
    pages = sorted((dataset / "qc").rglob("*.html"))
    before = {p: p.stat().st_mtime_ns for p in pages}
    write_dashboard(dataset)
    assert {p: p.stat().st_mtime_ns for p in pages} == before
    # a changed record: only its page (and the index, whose table shows it) is rendered again
    record = store.read_record(dataset, "s1_clean")
    assert record is not None
    store.write_record(dataset, replace(record, subject="renamed"))
    try:
        write_dashboard(dataset)
        changed = {p.name for p in pages if p.stat().st_mtime_ns != before[p]}
        assert changed == {"s1_clean.html", "index.html"}
    finally:
        store.write_record(dataset, record)
        write_dashboard(dataset)


# --------------------------------------------------------------------------------------------------
# Headless Chromium (gesturebank.testing.browser)


def _problems(events: list[dict[str, Any]], page: Path) -> list[str]:
    """Console errors and warnings, exceptions, and any request but the page itself."""
    found = []
    for e in events:
        method, params = e.get("method"), e.get("params", {})
        if method == "Runtime.exceptionThrown":
            found.append(f"exception: {params['exceptionDetails'].get('text')}")
        elif method == "Runtime.consoleAPICalled" and params.get("type") in ("error", "warning"):
            found.append(f"console {params['type']}: {params.get('args')}")
        elif method == "Log.entryAdded" and params["entry"]["level"] in ("error", "warning"):
            found.append(f"log: {params['entry'].get('text')}")
        elif method == "Network.requestWillBeSent":
            url = params["request"]["url"]
            if url != page.as_uri() and not url.startswith("data:"):
                found.append(f"request: {url}")
    return found


def _count(tab: Tab, selector: str) -> int:
    return int(tab.eval(f"document.querySelectorAll({json.dumps(selector)}).length"))


def _column(tab: Tab, col: int) -> list[str]:
    return tab.eval(
        f"Array.from(document.querySelectorAll('#takes tbody tr'))"
        f".map(function (r) {{ return r.cells[{col}].textContent; }})"
    )


@pytest.fixture()
def browser() -> Any:
    if not Path(CHROMIUM).is_file():
        pytest.skip("needs Debian's chromium")
    with tempfile.TemporaryDirectory() as profile:
        b = Browser(profile)
        try:
            yield b
        finally:
            b.close()


def test_index_draws_its_charts_and_sorts_in_chromium(
    dataset: Path, browser: Browser, artifacts: Path
) -> None:
    index = dataset / "qc" / "index.html"
    tab = browser.open(index.as_uri())
    assert _count(tab, "svg.jerk-clips rect.bar") == 2 * 8  # raw and processed per clip
    assert _count(tab, "svg.jerk-joints rect.bar") == 2 * 11
    usable = [float(v) for v in _column(tab, 4)]
    assert usable == sorted(usable, reverse=True)
    tab.click("#takes th:first-child")
    takes = _column(tab, 0)
    assert takes == sorted(takes)
    tab.click("#takes th:first-child")
    assert _column(tab, 0) == sorted(takes, reverse=True)
    tab.click("#takes th:nth-child(5)")
    assert [float(v) for v in _column(tab, 4)] == sorted(usable)
    tab.screenshot(artifacts / "qc-dashboard-index.png")
    tab.close()
    assert _problems(browser.events, index) == []


def _after(tab: Tab, selector: str) -> str:
    """The rendered text of an element's ::after (CSS `content`, quotes removed)."""
    return tab.eval(
        f"getComputedStyle(document.querySelector({json.dumps(selector)}), '::after')"
        ".content.replace(/^\"|\"$/g, '')"
    )


def test_sort_arrows_and_chart_labels_render_in_chromium(
    dataset: Path, browser: Browser, artifacts: Path
) -> None:
    index = dataset / "qc" / "index.html"
    tab = browser.open(index.as_uri())
    assert _after(tab, "#takes th:nth-child(5)") == " ▼"  # sorted by usable s, descending
    assert _after(tab, "#takes th:first-child") == " ⇅"  # sortable, not sorted
    tab.click("#takes th:first-child")
    assert _after(tab, "#takes th:first-child") == " ▲"
    assert _after(tab, "#takes th:nth-child(5)") == " ⇅"
    assert "\\" not in tab.eval("document.querySelector('#takes thead').innerText")
    tab.screenshot(artifacts / "qc-dashboard-sorted.png")
    tab.close()
    assert _problems(browser.events, index) == []


def test_long_clip_ids_fit_in_the_jerk_chart_in_chromium(
    tmp_path: Path, browser: Browser, artifacts: Path
) -> None:
    take = "subject07_lab_cam01_arctic_a0001_second_session"  # ids as long as real ones
    write_dataset(tmp_path, {take: [_clean(take, k, 70 + k) for k in range(3)]})
    refresh(tmp_path, Config())
    index = write_dashboard(tmp_path)
    tab = browser.open(index.as_uri())
    outside = tab.eval(  # labels reaching past their chart's box (cut off when drawn)
        "Array.from(document.querySelectorAll('svg.chart')).map(function (svg) {"
        " var box = svg.getBoundingClientRect();"
        " return Array.from(svg.querySelectorAll('text')).filter(function (t) {"
        "  var r = t.getBoundingClientRect();"
        "  return r.bottom > box.bottom + 0.5 || r.right > box.right + 0.5 || r.left < box.left;"
        " }).map(function (t) { return t.textContent; }); })"
    )
    assert outside == [[], []]
    assert _count(tab, "svg.jerk-clips text.label") == 3
    tab.screenshot(artifacts / "qc-dashboard-long-ids.png")
    tab.close()


def test_failed_metric_is_marked_in_chromium(
    dataset: Path, browser: Browser, artifacts: Path
) -> None:
    page = dataset / "qc" / "takes" / "s3_unseen.html"
    tab = browser.open(page.as_uri())
    row = "table.metrics tr[data-metric=head_unknown_fraction]"
    shown = tab.eval(
        f"(function (r) {{ r.scrollIntoView(); var s = getComputedStyle(r.cells[0]);"
        f" return [r.className, r.innerText, s.backgroundColor, s.fontWeight]; }})"
        f"(document.querySelector({json.dumps(row)}))"
    )
    assert shown[0] == "fail" and "✗ over the max" in shown[1] and "max 50 %" in shown[1]
    assert shown[2] == "rgb(253, 236, 234)" and int(shown[3]) >= 700  # red-tinted, bold
    passed = "table.metrics tr[data-metric=people]"
    assert tab.eval(f"document.querySelector({json.dumps(passed)}).className") == ""
    tab.call(
        "Emulation.setDeviceMetricsOverride",
        {"width": 1400, "height": 1000, "deviceScaleFactor": 1, "mobile": False},
    )
    tab.screenshot(artifacts / "qc-dashboard-failed-metric.png")
    tab.close()
    assert _problems(browser.events, page) == []
    assert (artifacts / "qc-dashboard-failed-metric.png").stat().st_size > 20_000


def test_take_page_draws_timeline_skeletons_and_angles_in_chromium(
    dataset: Path, browser: Browser, artifacts: Path
) -> None:
    page = dataset / "qc" / "takes" / "s4_mixed.html"
    tab = browser.open(page.as_uri())
    for kind in ("kept", "rejected", "dropped"):
        assert _count(tab, f"svg.timeline rect.seg.{kind}") == 1, kind
    assert "main speaker absent" in tab.eval(
        "document.querySelector('svg.timeline rect.seg.dropped title').textContent"
    )
    assert _count(tab, "svg.timeline line.cut") == 1
    assert _count(tab, "svg.timeline rect.speaker") == 2
    # the speech lane: each clip's span, the synthetic speaker heard throughout each
    assert _count(tab, "svg.timeline rect.silence") == _count(tab, "svg.timeline rect.speech") == 2
    assert _count(tab, "svg.preview image") == 1
    assert _count(tab, "svg.preview line.bone") >= 3 * 10  # three frames with a skeleton
    assert _count(tab, "svg.angles") == 2
    assert _count(tab, "svg.angles g.joint-plot") == 2 * 11
    assert _count(tab, "svg.angles path.proc") == _count(tab, "svg.angles path.raw") == 22
    tab.screenshot(artifacts / "qc-dashboard-take.png")
    tab.close()
    assert _problems(browser.events, page) == []

    masked = dataset / "qc" / "takes" / "s2_masked.html"
    tab = browser.open(masked.as_uri())
    assert _count(tab, "svg.angles rect.masked") >= 11
    assert _count(tab, "svg.angles rect.repaired") == 2  # LElbowRoll, LElbowYaw: the wrist
    tab.screenshot(artifacts / "qc-dashboard-masked.png")
    tab.close()
    assert _problems(browser.events, masked) == []
    assert (artifacts / "qc-dashboard-take.png").stat().st_size > 50_000


def test_take_page_timeline_shows_where_speech_was_heard(dataset: Path) -> None:
    """The speech lane: each clip's span (measured) and the runs of speech in it, in source
    seconds; s1_clean's first clip pauses from 1.0 to 1.5 s."""
    speech = _data(_page(dataset, "s1_clean"))["timeline"]["speech"]
    first, second = speech["measured"]
    assert first[0] == pytest.approx(0.0, abs=0.02) and first[1] == pytest.approx(second[0])
    assert second[1] == pytest.approx(2 * SECONDS, abs=0.1)  # two clips of 8 s, one after other
    runs = speech["heard"]
    assert len(runs) == 3  # the first clip's speech either side of its pause, the second's
    assert runs[0][1] == pytest.approx(1.0, abs=0.011) and runs[1][0] == pytest.approx(
        1.5, abs=0.011
    )
    assert runs[2] == pytest.approx(second, abs=0.011)


def test_take_page_timeline_shows_the_depth_confidence(dataset: Path) -> None:
    """The depth lane: pieces of each clip's depth confidence in source seconds; s1_clean's
    first clip doubts its depth signs (0.6) from 2 to 3 s, the rest is certain (1.0)."""
    depth = _data(_page(dataset, "s1_clean"))["timeline"]["depth"]
    assert [d[2] for d in depth] == [1.0, DOUBT[2], 1.0, 1.0]  # merged: 4 pieces, 2 clips
    low = depth[1]
    assert low[0] == pytest.approx(DOUBT[0], abs=0.04) and low[1] == pytest.approx(
        DOUBT[1], abs=0.04
    )
    assert depth[-1][1] == pytest.approx(2 * SECONDS, abs=0.1)


def test_depth_lane_is_drawn_in_chromium(dataset: Path, browser: Browser) -> None:
    page = dataset / "qc" / "takes" / "s1_clean.html"
    tab = browser.open(page.as_uri())
    assert _count(tab, "svg.timeline rect.depth") == 4
    tips = tab.eval(
        "Array.from(document.querySelectorAll('svg.timeline rect.depth title'))"
        ".map(function (t) { return t.textContent; })"
    )
    assert sum("depth confidence 0.60" in t for t in tips) == 1
    fills = tab.eval(
        "Array.from(document.querySelectorAll('svg.timeline rect.depth'))"
        ".map(function (r) { return getComputedStyle(r).fill; })"
    )
    assert fills[1] != fills[0]  # the doubtful piece has its own colour
    row = "table.metrics tr[data-metric=depth_confidence]"
    shown = tab.eval(f"document.querySelector({json.dumps(row)}).innerText")
    assert "depth confidence" in shown
    tab.close()
    assert _problems(browser.events, page) == []


def test_role_runs_are_the_person_lane_of_the_timeline(dataset: Path) -> None:
    """One lane per person: the runs of their roles in source seconds; the fixture's clips
    know no roles (one unknown run per clip, person 0)."""
    people = _data(_page(dataset, "s1_clean"))["timeline"]["people"]
    assert [lane["person"] for lane in people] == [0]
    assert {run[2] for run in people[0]["runs"]} == {"unknown"}
    clip = synthetic_clip(seconds=2.0)
    n = len(clip.times)
    role = np.zeros(n, np.int8)
    role[n // 2 :] = ROLES.index("speaking")
    runs = role_runs(replace(clip, role=role, start_s=10.0))
    assert [r[2] for r in runs] == ["unknown", "speaking"]
    assert runs[0][0] == pytest.approx(10.0) and runs[0][1] == pytest.approx(runs[1][0])
    assert runs[1][1] == pytest.approx(10.0 + clip.duration_s, abs=0.011)


def test_head_runs_are_the_head_lane_of_the_timeline(dataset: Path, browser: Browser) -> None:
    """The head lane: runs of each clip's head source (per video frame) in source seconds,
    drawn one rect per run; the fixture's clips were built in memory (source none)."""
    heads = _data(_page(dataset, "s1_clean"))["timeline"]["head"]
    assert heads and {h[2] for h in heads} == {"none"}
    clip = synthetic_clip(seconds=2.0)
    t = len(clip.timestamps)
    source = np.full(t, HEAD_SOURCES.index("face"), np.int8)
    source[t // 2 :] = HEAD_SOURCES.index("body")
    runs = head_runs(replace(clip, head_source=source, start_s=10.0))
    assert [r[2] for r in runs] == ["face", "body"]
    assert runs[0][0] == pytest.approx(10.0) and runs[0][1] == pytest.approx(runs[1][0])
    tab = browser.open((dataset / "qc" / "takes" / "s1_clean.html").as_uri())
    assert _count(tab, "svg.timeline rect.head") == len(heads)
    tab.close()
