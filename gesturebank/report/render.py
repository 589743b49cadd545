"""The QC dashboard's HTML: the index (usable and visible seconds, clips by status, a sortable
table of takes, the reasons time was lost, jerk per clip as Fig. 4.7 and mean jerk per joint as
Fig. 4.9) and a page per take (timeline, main speaker, preview strip, and per clip its verdict,
metrics beside their thresholds and its angles), from what `report.data` shapes.

Each page embeds its data as JSON and one small script draws the charts as SVG from it; a
Content-Security-Policy forbids every request, so a page works offline and alone.
"""

from __future__ import annotations

import html
import json
import logging
import math
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any
from urllib.parse import quote

import numpy as np

from gesturebank.clip import Clip
from gesturebank.config import QCConfig
from gesturebank.datasets import store
from gesturebank.qc import checks
from gesturebank.qc.table import CHECKS, UNITS, by_metric
from gesturebank.report.data import (
    PAGES_DIR,
    PLOT_RATE_HZ,
    jerk_data,
    kept_share,
    kind_of,
    load_clip,
    lost_s,
    parts_of,
    speaker_choices,
    take_data,
    time_lost,
)

log = logging.getLogger(__name__)

_CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'"

# Metrics of a clip as shown: key, label, format of the scaled value, scale. Those a check
# judges take their label and unit from the table of checks (`qc.table`); these are reported.
_REPORTED = (
    ("duration_s", "duration", "{:.2f} s", 1.0),
    ("jerk", "processed jerk", "{:.3g} rad²/s⁵", 1.0),
    ("left_arm_unknown_fraction", "left arm unseen", "{:.0f} %", 100.0),
    ("right_arm_unknown_fraction", "right arm unseen", "{:.0f} %", 100.0),
    ("torso_gap_s", "longest torso gap", "{:.2f} s", 1.0),
    ("depth_confidence", "depth confidence", "{:.2f}", 1.0),
)


def _metric_rows() -> list[tuple[str, str, str, float]]:
    """(key, label, format, scale) of every metric the page shows by name, checks' first."""
    checked = [(c.metric, c.label, *UNITS[c.unit]) for c in CHECKS]
    return [*checked, *(r for r in _REPORTED if r[0] not in {c[0] for c in checked})]


# The page's style, and its script that draws every chart from the page's JSON (id "data") and
# sorts tables whose header is clicked; inlined into every page (pages work offline and alone).
STYLE = resources.files("gesturebank.report").joinpath("dashboard.css").read_text(encoding="utf-8")
SCRIPT = resources.files("gesturebank.report").joinpath("dashboard.js").read_text(encoding="utf-8")


def _to_json(data: Any) -> str:
    """Compact JSON that is safe inside a <script> element (no "<" can close it)."""
    text = json.dumps(data, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    return text.replace("<", "\\u003c")


def _metric_text(metrics: Mapping[str, float], key: str, fmt: str, scale: float) -> str:
    v = metrics.get(key)
    return fmt.format(v * scale) if v is not None and math.isfinite(v) else "–"


# --------------------------------------------------------------------------------------------------
# HTML


def _e(value: object) -> str:
    return html.escape(str(value))


def _page(title: str, body: str, data: Mapping[str, Any], key: str = "") -> str:
    """A self-contained page: its data as JSON, the script that draws it, a CSP without any
    source. The page key sits on the second line, where `report.cache` looks for it."""
    return (
        f"<!DOCTYPE html>\n<!-- page-key {key or 'none'} -->\n<html lang='en'><head>"
        "<meta charset='utf-8'>"
        f"<meta http-equiv='Content-Security-Policy' content=\"{_CSP}\">"
        f"<title>{_e(title)}</title><style>{STYLE}</style></head><body>{body}"
        f"<script type='application/json' id='data'>{_to_json(data)}</script>"
        f"<script>{SCRIPT}</script></body></html>\n"
    )


def _tag(kind: str) -> str:
    return f"<span class='tag {kind}'>{kind}</span>"


def _table(
    head: Sequence[tuple[str, str]],
    rows: Iterable[str],
    *,
    cls: str = "",
    id_: str = "",
    sorted_by: int | None = None,
) -> str:
    """head: (text, css class) per column; rows: finished <tr> markup, already in the order of
    column `sorted_by` (descending), which the header then shows."""
    ths = "".join(
        f"<th class='{c}'{' aria-sort=descending' if i == sorted_by else ''}>{_e(t)}</th>"
        for i, (t, c) in enumerate(head)
    )
    attrs = (f" class='{cls}'" if cls else "") + (f" id='{id_}'" if id_ else "")
    return f"<table{attrs}><thead><tr>{ths}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def _td(text: str, value: float | str | None = None, cls: str = "") -> str:
    """A cell; `value` (data-v) is what sorting compares."""
    v = "" if value is None else f" data-v='{_e(value)}'"
    c = f" class='{cls}'" if cls else ""
    return f"<td{c}{v}>{text}</td>"


# --------------------------------------------------------------------------------------------------
# Index


def _summary(records: Sequence[store.TakeRecord]) -> str:
    parts = [c for r in records for c in parts_of(r)]
    count = Counter(kind_of(c) for c in parts)
    usable = sum(r.usable_s for r in records)
    visible = sum(r.visible_s for r in records)
    dropped_s = sum(lost_s(c) for c in parts if kind_of(c) == "dropped")
    cut_s = sum(lost_s(c) for c in parts if kind_of(c) == "cut")
    cells = [
        ("usable seconds", f"{usable:.1f}"),
        ("seconds the speaker was visible", f"{visible:.1f}"),
        ("share kept", f"{usable / visible:.0%}" if visible > 0 else "–"),
        ("clips kept", str(count["kept"])),
        ("clips rejected", str(count["rejected"])),
        # the spans of every kind (dataset.json's stretches_dropped); those the QC cut out of
        # clips (issue 41) are also counted alone
        ("stretches dropped", f"{count['dropped'] + count['cut']} ({dropped_s + cut_s:.1f} s)"),
        ("of them cut by the QC", f"{count['cut']} ({cut_s:.1f} s)"),
        ("takes failed", str(sum(bool(r.failed) for r in records))),
    ]
    head = "".join(f"<th>{_e(k)}</th>" for k, _ in cells)
    values = "".join(f"<td id='sum-{i}'>{_e(v)}</td>" for i, (_, v) in enumerate(cells))
    return f"<table class='big'><tr>{head}</tr><tr>{values}</tr></table>"


def _take_row(r: store.TakeRecord) -> str:
    clips = r.data_clips
    accepted = sum(c.qc_status == "accepted" for c in clips)
    lost = list(time_lost(parts_of(r)).items())[:3]
    top = ", ".join(f"{_e(k)} ({s:.1f} s)" for k, (s, _) in lost)
    status = "failed" if r.failed else "built"
    link = f"<a href='{PAGES_DIR}/{quote(r.take_id)}.html'>{_e(r.take_id)}</a>"
    share = kept_share(r)
    return (
        "<tr>"
        + "".join(
            [
                _td(link, r.take_id, "l"),
                _td(_e(r.subject), r.subject, "l"),
                _td(f"<span class='{status}'>{status}</span>", status, "l"),
                _td(f"{accepted}/{len(clips)}", accepted),
                _td(f"{r.usable_s:.1f}", round(r.usable_s, 3)),
                _td(f"{r.visible_s:.1f}", round(r.visible_s, 3)),
                _td(f"{share:.0%}", round(share, 4)),
                _td(top or "–", None, "l"),
            ]
        )
        + "</tr>"
    )


def _takes_table(records: Sequence[store.TakeRecord]) -> str:
    """Every take, most usable seconds first (click a header to sort by it)."""
    ordered = sorted(records, key=lambda r: (-r.usable_s, r.take_id))
    head = [("take", "l"), ("subject", "l"), ("status", "l"), ("clips accepted/total", "")]
    head += [("usable s", ""), ("visible s", ""), ("share kept", ""), ("most time lost to", "l")]
    return _table(head, map(_take_row, ordered), cls="sortable", id_="takes", sorted_by=4)


def _reasons_table(records: Sequence[store.TakeRecord]) -> str:
    lost = time_lost(c for r in records for c in parts_of(r))
    if not lost:
        return "<p>No time was lost: every clip was accepted and nothing was dropped.</p>"
    rows = []
    for reason, (s, where) in lost.items():  # most seconds first
        found = ", ".join(f"{n} {k}" for k, n in sorted(where.items()))
        cells = _td(_e(reason), reason, "l") + _td(found, None, "l")
        rows.append(f"<tr>{cells}{_td(f'{s:.1f}', round(s, 3))}</tr>")
    head = [("reason", "l"), ("clips / spans", "l"), ("seconds", "")]
    note = "<p class='note'>A clip rejected for several reasons counts under each.</p>"
    return _table(head, rows, cls="sortable", id_="reasons", sorted_by=2) + note


def index_page(out: Path, *, info: store.DatasetInfo, records: Sequence[store.TakeRecord]) -> str:
    data = jerk_data(records, info.joints)
    body = [
        "<h1>gesturebank QC</h1>",
        f"<p class='note'>{_e(out)}: {len(records)} takes. Click a column header to sort, a take "
        "for its timeline and clips.</p>",
        _summary(records),
        "<h2>Takes</h2>",
        _takes_table(records),
        "<h2>Where time was lost</h2>",
        _reasons_table(records),
        "<h2>Jerkiness per clip (Eq. 3.21, summed over the joints)</h2>",
        "<p class='note'>Solid: raw angles (on the analysis clock); pale: processed (100 Hz). "
        "Green accepted, red rejected. Click a bar for its clip.</p>",
        "<div id='jerk-clips'></div>",
        f"<h2>Mean jerkiness per joint over the {_e(data['joint_over'])}</h2>",
        "<p class='note'>Orange: raw; blue: processed.</p>",
        "<div id='jerk-joints'></div>",
    ]
    return _page("gesturebank QC", "".join(body), data)


# --------------------------------------------------------------------------------------------------
# Take page: HTML


def _facts(record: store.TakeRecord) -> str:
    fps = f"{record.video_fps:.2f} fps" if math.isfinite(record.video_fps) else "fps unknown"
    items = [
        f"subject <b>{_e(record.subject)}</b>",
        f"source {_e(record.source)}",
        f"detector {_e(record.detector or '–')}, lifter {_e(record.lifter or '–')}, {fps}",
        f"{record.seconds:.1f} s looked at, speaker visible {record.visible_s:.1f} s, "
        f"usable {record.usable_s:.1f} s (kept {kept_share(record):.0%})",
    ]
    return "<p>" + " · ".join(items) + "</p>"


def _segment_list(record: store.TakeRecord) -> str:
    items = []
    for c in parts_of(record):
        kind = kind_of(c)
        what = (
            f"<a href='#{quote(c.clip_id)}'>{_e(c.clip_id)}</a>"
            if c.kind == "clip"
            else _e(c.clip_id)
        )
        why = f": {_e('; '.join(c.qc_reasons))}" if c.qc_reasons else ""
        items.append(
            f"<li class='{kind}'>{c.start_s:.2f}–{c.end_s:.2f} s {_tag(kind)} {what}{why}</li>"
        )
    return f"<ol class='segments'>{''.join(items)}</ol>"


def _tracking_table(choices: Sequence[Mapping[str, Any]]) -> str:
    if not choices:
        return "<p class='note'>No main-speaker report in this take's record.</p>"
    terms: list[str] = []
    for c in choices:
        for scores in c["scores"].values():
            terms += [t for t in scores if t not in terms]
    terms.sort(key=lambda t: t != "total")  # the total first, then the terms as reported
    head = [
        ("from–to s", ""),
        ("shot", ""),
        ("starts because", "l"),
        ("main", ""),
        ("runner-up", ""),
    ]
    head += [(f"{t} main / runner-up", "") for t in terms]
    rows = []
    for c in choices:
        main, runner = c["scores"].get(str(c["main"]), {}), c["scores"].get(str(c["runner"]), {})

        def pair(t: str, main: Mapping[str, Any] = main, runner: Mapping[str, Any] = runner) -> str:
            a, b = main.get(t), runner.get(t)
            return f"{'–' if a is None else f'{a:.3g}'} / {'–' if b is None else f'{b:.3g}'}"

        cells = [
            f"{c['t0']:.2f}–{c['t1']:.2f}",
            _e(c["shot"]),
            _e(c["reason"]),
            "nobody" if c["main"] < 0 else f"#{c['main']}",
            "–" if c["runner"] is None else f"#{c['runner']}",
            *(pair(t) for t in terms),
        ]
        rows.append(
            "<tr>"
            + "".join(_td(x, None, "l" if i == 2 else "") for i, x in enumerate(cells))
            + "</tr>"
        )
    return _table(head, rows, id_="speakers")


def _preview_html(preview: Mapping[str, Any] | None, record: store.TakeRecord) -> str:
    if preview is None:
        return "<p class='note'>No preview strip for this take (no preview.jpg).</p>"
    notes = "".join(f"<li>{f['t']:.2f} s: {_e(f['note'])}</li>" for f in preview["frames"])
    legend = (
        "<p class='note'>Main speaker's 2D skeleton as repaired (cyan: left side, orange: right; "
        "red dots: repaired keypoints; only keypoints seen are drawn).</p>"
    )
    return f"<div id='preview'></div>{legend}<ol class='frames'>{notes}</ol>"


def _readable(key: str) -> str:
    """A label for a metric the page has none for: 'trimmed_fraction' → 'trimmed (share)'."""
    *words, last = key.split("_")
    unit = {"fraction": " (share)", "s": " (s)"}.get(last)
    return " ".join(words) + unit if unit and words else " ".join([*words, last])


def _threshold_text(key: str, fmt: str, scale: float, qc: QCConfig) -> str:
    """The clip's limit on metric `key` in the metric's own unit, and its outlier rule."""
    parts = []
    check = checks.threshold(key, qc)
    if check is not None:
        parts.append(f"{check[0]} {fmt.format(check[1] * scale)}")
    if key in qc.outlier_metrics:
        parts.append(
            f"outlier if > {qc.outlier_min_ratio:g}× dataset median and robust z > {qc.outlier_z:g}"
        )
    return "; ".join(parts)


def _verdict(key: str, value: float | None, reasons: Sequence[str], qc: QCConfig) -> str:
    """'✗ over the max', '✗ under the min', '✗ outlier', '✓' (checked, passed) or ''."""
    failed = []
    check = by_metric(key)
    if check is not None and check.fails(value, qc):
        failed.append("over the max" if check.side == "max" else "under the min")
    if any(checks.is_outlier_reason(key, r) for r in reasons):
        failed.append("outlier")
    if failed:
        return "✗ " + ", ".join(failed)
    checked = checks.threshold(key, qc) is not None or key in qc.outlier_metrics
    return "✓" if checked and value is not None and math.isfinite(value) else ""


def _metrics_table(metrics: Mapping[str, float], reasons: Sequence[str], qc: QCConfig) -> str:
    """The clip's metrics (not the per-joint ones), each beside its threshold; the rows of the
    checks it failed are marked (class 'fail', ✗)."""
    named = _metric_rows()
    shown = {k for k, *_ in named}
    rows_of = [(k, label, fmt, scale) for k, label, fmt, scale in named if k in metrics]
    rows_of += [
        (k, _readable(k), "{:.4g}", 1.0) for k in sorted(metrics) if "/" not in k and k not in shown
    ]
    rows = []
    for key, label, fmt, scale in rows_of:
        value = metrics.get(key)
        verdict = _verdict(key, value, reasons, qc)
        cls = " class='fail'" if verdict.startswith("✗") else ""
        cells = [
            f"<td class='l' title='{_e(key)}'>{_e(label)}</td>",
            f"<td>{_e(_metric_text(metrics, key, fmt, scale))}</td>",
            f"<td class='l'>{_e(_threshold_text(key, fmt, scale, qc)) or '–'}</td>",
            f"<td class='l verdict'>{_e(verdict)}</td>",
        ]
        rows.append(f"<tr{cls} data-metric='{_e(key)}'>{''.join(cells)}</tr>")
    head = "".join(f"<th class='l'>{h}</th>" for h in ("metric", "value", "threshold", "check"))
    return (
        f"<table class='metrics'><thead><tr>{head}</tr></thead>"
        f"<tbody>{''.join(rows)}</tbody></table>"
    )


def _masked_text(clip: Clip, joints: Sequence[str]) -> str:
    """Share of the clip each angle is unknown, from its `mask`."""
    share = np.mean(~np.asarray(clip.mask, dtype=bool), axis=0) if len(clip.mask) else []
    if not np.any(share):
        return "none"
    if np.allclose(share, share[0]):
        return f"every angle {share[0]:.0%} of the clip"
    return ", ".join(f"{j} {v:.0%}" for j, v in zip(joints, share, strict=True) if v > 0)


def _reach_text(metrics: Mapping[str, float], joints: Sequence[str]) -> str:
    """Share of its known frames each joint's person angle lies beyond the robot's limits
    (`out_of_reach/<Joint>`): reported, not judged (the reach map keeps the motion)."""
    share = {j: float(metrics.get(f"out_of_reach/{j}", math.nan) or 0.0) for j in joints}
    shown = [f"{j} {v:.0%}" for j, v in share.items() if v > 0]
    return ", ".join(shown) if shown else "none"


def _clip_html(
    n: int, c: store.ClipRecord, clip: Clip | str, joints: Sequence[str], qc: QCConfig
) -> str:
    kind = kind_of(c)
    reasons = "".join(f"<li>{_e(r)}</li>" for r in c.qc_reasons)
    if isinstance(clip, Clip):
        repaired = np.asarray(clip.repaired, dtype=bool)
        fixed = (
            f"{int(repaired.sum())} in {int(repaired.any(axis=1).sum())} video frames"
            if repaired.any()
            else "none"
        )
        arrays = (
            f"Keypoints repaired: {fixed}. "
            f"Angles unknown (masked): {_e(_masked_text(clip, joints))}. "
            f"Beyond the robot's reach: {_e(_reach_text(c.metrics, joints))}."
        )
        plot = f"<div id='angles-{n}'></div>"
    else:
        arrays, plot = "", f"<p class='rejected'>No plots: {_e(clip)}</p>"
    return (
        f"<section class='clip' id='{_e(c.clip_id)}'><h3>{_e(c.clip_id)} {_tag(kind)}</h3>"
        f"<p>{c.start_s:.2f}–{c.end_s:.2f} s of the source, {c.duration_s:.2f} s at 100 Hz "
        f"({c.n_frames} frames). {arrays}</p>"
        + (f"<p>Rejected because:</p><ul class='reasons'>{reasons}</ul>" if reasons else "")
        + _metrics_table(c.metrics, c.qc_reasons, qc)
        + "<h4>Angles: raw (video frames) vs processed (100 Hz), with the robot's limits "
        f"<span class='note'>(plotted at up to {PLOT_RATE_HZ:g} points a second)</span></h4>"
        f"{plot}</section>"
    )


def _clip_sections(
    record: store.TakeRecord,
    clips: Mapping[str, Clip | str],
    joints: Sequence[str],
    qc: QCConfig,
) -> list[str]:
    """One section per clip, in time order; plot n is the n-th clip whose arrays could be read
    (the order of the page data's clips)."""
    sections, n = [], 0
    for c in record.data_clips:
        clip = clips[c.clip_id]
        sections.append(_clip_html(n, c, clip, joints, qc))
        n += isinstance(clip, Clip)
    return sections


_SPEAKER_NOTE = (
    "<p class='note' id='speaker-note'>Speaker row: who was followed as the main speaker in each "
    "stretch, by their person number in this take's tracking (“#1 (runner-up #4)”: person 1 "
    "was chosen over person 4, the next best candidate; grey: nobody). Hover a stretch for both "
    "scores; all of them are under Main speaker.</p>"
)


def take_page(out: Path, *, record: store.TakeRecord, info: store.DatasetInfo, key: str) -> str:
    clips = {
        c.clip_id: load_clip(out, take_id=record.take_id, clip_id=c.clip_id)
        for c in record.data_clips
    }
    choices = speaker_choices(record.tracking)
    data = take_data(out, record=record, info=info, clips=clips, choices=choices)
    body = [
        "<p><a href='../index.html'>← all takes</a></p>",
        f"<h1>{_e(record.take_id)}</h1>",
        _facts(record),
        f"<p class='failed'>The take failed: {_e(record.failed)}</p>" if record.failed else "",
        "<h2>Timeline</h2>",
        "<div id='timeline'></div>",
        f"<p class='note'>{_tag('kept')} {_tag('rejected')} {_tag('cut')} {_tag('dropped')} "
        "(cut: a stretch the QC cut out of a clip, the rest kept) dashed lines: "
        "shot cuts (from the main-speaker report); ▲ preview frames. Hover a segment for its "
        "reasons.</p>",
        _SPEAKER_NOTE if choices else "",
        _segment_list(record),
        "<h2>Main speaker</h2>",
        _tracking_table(choices),
        "<h2>Preview frames</h2>",
        _preview_html(data["preview"], record),
        "<h2>Clips</h2>" if record.data_clips else "",
        *_clip_sections(record, clips, info.joints, info.config.qc),
    ]
    return _page(f"QC {record.take_id}", "".join(body), data, key)


def render_take(out: Path, *, record: store.TakeRecord, info: store.DatasetInfo, key: str) -> str:
    """The take's page; one that cannot be drawn says why (and is tried again next time)."""
    try:
        return take_page(out, record=record, info=info, key=key)
    except Exception as exc:  # one odd take must not cost the dashboard of every other
        log.warning("%s: cannot draw its QC page (%s)", record.take_id, exc, exc_info=True)
        body = f"<h1>{_e(record.take_id)}</h1><p class='failed'>Page not drawn: {_e(exc)}</p>"
        return _page(f"QC {record.take_id}", body, {"page": "error"})
