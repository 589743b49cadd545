"""The QC dashboard of a clip dataset: static HTML pages that work offline.

    OUT/qc/index.html          usable and visible seconds, clips by status, a sortable table of
                               takes, the reasons time was lost, jerk per clip (as Fig. 4.7) and
                               mean jerk per joint (as Fig. 4.9)
    OUT/qc/takes/<id>.html     the take's timeline (clips kept / rejected, spans dropped, shot
                               cuts, main speaker), the preview strip with the main speaker's 2D
                               skeleton, and per clip its verdict, metrics and the 11 angles raw
                               vs processed with the robot's limits, masked spans and repairs

Pages are drawn from the records and clips as they are (`datasets.refresh` judges the clips).
Each page embeds its data as JSON and one small script draws the charts as SVG from it; a
Content-Security-Policy forbids every request. A take page carries a key of what it shows and is
only rendered again when the key changes, so an unchanged dataset costs a read of its records.
"""

from __future__ import annotations

import base64
import hashlib
import html
import itertools
import json
import logging
import math
import re
from collections import Counter, defaultdict
from collections.abc import Iterable, Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any
from urllib.parse import quote

import numpy as np

from gesturebank.clip import Clip
from gesturebank.config import QCConfig
from gesturebank.datasets import store
from gesturebank.datasets.cut import frame_ends
from gesturebank.errors import InputError
from gesturebank.fileio import write_bytes_atomic
from gesturebank.qc import checks
from gesturebank.robot.retarget import NEEDS
from gesturebank.skeletons import COCO17, COCO17_BONES, to_coco17

log = logging.getLogger(__name__)

QC_DIR = "qc"
PAGES_DIR = "takes"
PLOT_RATE_HZ = 25.0  # at most this many points per second of a plotted series
_CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'"
_KEY = re.compile(r"<!-- page-key (\w+) -->")
_NUMBER = re.compile(r"(?<![\w.])[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?(?![A-Za-z])")
_SHOULDERS = ("left_shoulder", "right_shoulder")  # every angle needs both (retarget.NEEDS)

# Metrics of a clip as shown: key, label, format of the scaled value, scale.
_METRICS = (
    ("duration_s", "duration", "{:.2f} s", 1.0),
    ("jerk_raw", "raw jerk", "{:.3g} rad²/s⁵", 1.0),
    ("jerk", "processed jerk", "{:.3g} rad²/s⁵", 1.0),
    ("head_unknown_fraction", "head unseen", "{:.0f} %", 100.0),
    ("arms_unknown_fraction", "both arms unseen", "{:.0f} %", 100.0),
    ("torso_gap_s", "longest torso gap", "{:.2f} s", 1.0),
    ("bone_cv_max", "bone length variation", "{:.1f} %", 100.0),
    ("out_of_reach_fraction", "beyond reach", "{:.0f} %", 100.0),
    ("frozen_at_limit_s", "frozen at a limit", "{:.1f} s", 1.0),
    ("jitter_fraction", "raw power above the jitter band", "{:.1f} %", 100.0),
    ("swap_events", "left/right swaps", "{:.0f}", 1.0),
    ("spike_max", "largest spike", "{:.2f} shoulder widths", 1.0),
    ("frozen_fraction", "frozen pose", "{:.0f} %", 100.0),
    ("motion_range", "motion range", "{:.1f}°", float(np.degrees(1.0))),
    ("facing_away_fraction", "facing away", "{:.0f} %", 100.0),
    ("sideways_fraction", "seen from the side", "{:.0f} %", 100.0),
    ("shoulder_width", "shoulder width", "{:.1f} % of the frame height", 100.0),
    ("image_change", "image change", "{:.3f}", 1.0),
    ("people", "people in the frame", "{:.1f}", 1.0),
    ("trimmed_fraction", "take's video outside its audio", "{:.0f} %", 100.0),
)

# The page's style, and its script that draws every chart from the page's JSON (id "data") and
# sorts tables whose header is clicked; inlined into every page (pages work offline and alone).
_STYLE = resources.files("gesturebank.qc").joinpath("dashboard.css").read_text(encoding="utf-8")
_SCRIPT = resources.files("gesturebank.qc").joinpath("dashboard.js").read_text(encoding="utf-8")


# --------------------------------------------------------------------------------------------------
# Numbers for the page


def _sig(value: float, digits: int = 4) -> float | None:
    """`value` rounded to `digits` significant digits; None when not finite (JSON null)."""
    v = float(value)
    return float(f"{v:.{digits}g}") if math.isfinite(v) else None


def _steps(values: np.ndarray, unit: float) -> list[int | None]:
    """`values (N,)` in whole multiples of `unit`, each as its step from the previous finite one
    (the page's `undelta` adds them up): small integers, about half the bytes of the values."""
    q = np.round(np.asarray(values, dtype=np.float64) / unit)
    finite = np.isfinite(q)
    steps: list[int] = np.diff(q[finite].astype(np.int64), prepend=0).tolist()
    if finite.all():
        return list(steps)
    out: list[int | None] = [None] * len(q)
    for i, step in zip(np.flatnonzero(finite).tolist(), steps, strict=True):
        out[i] = step
    return out


def _stride(n: int, seconds: float) -> int:
    """Keep every how many of `n` samples over `seconds` for at most PLOT_RATE_HZ a second."""
    return max(1, math.ceil(n / max(seconds * PLOT_RATE_HZ, 1.0)))


def _runs(flags: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> list[list[float]]:
    """[from, to] seconds of every run of True in `flags (T,)`; frame i lasts starts[i]–ends[i]."""
    edges = np.diff(np.concatenate([[0], np.asarray(flags, dtype=np.int8), [0]]))
    a, b = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [
        [round(float(starts[i]), 3), round(float(ends[j - 1]), 3)]
        for i, j in zip(a, b, strict=True)
    ]


def _to_json(data: Any) -> str:
    """Compact JSON that is safe inside a <script> element (no "<" can close it)."""
    text = json.dumps(data, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    return text.replace("<", "\\u003c")


def _metric_text(metrics: Mapping[str, float], key: str, fmt: str, scale: float) -> str:
    v = metrics.get(key)
    return fmt.format(v * scale) if v is not None and math.isfinite(v) else "–"


def reason_kind(text: str) -> str:
    """A reason without its numbers and its parenthesis, so that alike reasons add up
    ("head unseen in 95% of the clip (max 50%)" → "head unseen in …% of the clip")."""
    return _NUMBER.sub("…", text.split(" (")[0]).strip()


# --------------------------------------------------------------------------------------------------
# What a take gave


def _kind(c: store.ClipRecord) -> str:
    """kept | rejected (clips with arrays) | dropped | failed (spans)."""
    if c.kind == "clip":
        return "kept" if c.qc_status == "accepted" else "rejected"
    return "failed" if c.qc_status == "failed" else "dropped"


def _parts(record: store.TakeRecord) -> tuple[store.ClipRecord, ...]:
    """The take's clips and spans; a failed take is one failed span over what was looked at."""
    if record.failed:
        return (
            store.ClipRecord(
                record.take_id, "span", 0.0, record.seconds, "failed", (record.failed,)
            ),
        )
    return tuple(sorted(record.clips, key=lambda c: c.start_s))


def _lost_s(c: store.ClipRecord) -> float:
    """Seconds a rejected clip or a dropped span cost."""
    return c.duration_s if c.kind == "clip" else max(0.0, c.end_s - c.start_s)


def _lost(parts: Iterable[store.ClipRecord]) -> dict[str, tuple[float, Counter[str]]]:
    """Per reason kind, most seconds first: the seconds lost to it and how many parts of each
    kind (rejected, dropped, failed) gave it. A part with two reasons counts under both."""
    seconds: defaultdict[str, float] = defaultdict(float)
    where: defaultdict[str, Counter[str]] = defaultdict(Counter)
    for c in parts:
        kind = _kind(c)
        if kind == "kept":
            continue
        for reason in c.qc_reasons or ("no reason recorded",):
            seconds[reason_kind(reason)] += _lost_s(c)
            where[reason_kind(reason)][kind] += 1
    order = sorted(seconds, key=lambda k: (-seconds[k], k))
    return {k: (seconds[k], where[k]) for k in order}


def _kept_share(record: store.TakeRecord) -> float:
    return record.usable_s / record.visible_s if record.visible_s > 0 else 0.0


# --------------------------------------------------------------------------------------------------
# HTML


def _e(value: object) -> str:
    return html.escape(str(value))


def _page(title: str, body: str, data: Mapping[str, Any], key: str = "") -> str:
    """A self-contained page: its data as JSON, the script that draws it, a CSP without any
    source. The page key sits on the second line, where `_existing_key` looks."""
    return (
        f"<!DOCTYPE html>\n<!-- page-key {key or 'none'} -->\n<html lang='en'><head>"
        "<meta charset='utf-8'>"
        f"<meta http-equiv='Content-Security-Policy' content=\"{_CSP}\">"
        f"<title>{_e(title)}</title><style>{_STYLE}</style></head><body>{body}"
        f"<script type='application/json' id='data'>{_to_json(data)}</script>"
        f"<script>{_SCRIPT}</script></body></html>\n"
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
    parts = [c for r in records for c in _parts(r)]
    count = Counter(_kind(c) for c in parts)
    usable = sum(r.usable_s for r in records)
    visible = sum(r.visible_s for r in records)
    dropped_s = sum(_lost_s(c) for c in parts if _kind(c) == "dropped")
    cells = [
        ("usable seconds", f"{usable:.1f}"),
        ("seconds the speaker was visible", f"{visible:.1f}"),
        ("share kept", f"{usable / visible:.0%}" if visible > 0 else "–"),
        ("clips accepted", str(count["kept"])),
        ("clips rejected", str(count["rejected"])),
        ("spans dropped", f"{count['dropped']} ({dropped_s:.1f} s)"),
        ("takes failed", str(sum(bool(r.failed) for r in records))),
    ]
    head = "".join(f"<th>{_e(k)}</th>" for k, _ in cells)
    values = "".join(f"<td id='sum-{i}'>{_e(v)}</td>" for i, (_, v) in enumerate(cells))
    return f"<table class='big'><tr>{head}</tr><tr>{values}</tr></table>"


def _take_row(r: store.TakeRecord) -> str:
    clips = r.data_clips
    accepted = sum(c.qc_status == "accepted" for c in clips)
    lost = list(_lost(_parts(r)).items())[:3]
    top = ", ".join(f"{_e(k)} ({s:.1f} s)" for k, (s, _) in lost)
    status = "failed" if r.failed else "built"
    link = f"<a href='{PAGES_DIR}/{quote(r.take_id)}.html'>{_e(r.take_id)}</a>"
    share = _kept_share(r)
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
    lost = _lost(c for r in records for c in _parts(r))
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


def _jerk_data(records: Sequence[store.TakeRecord], joints: Sequence[str]) -> dict[str, Any]:
    """Jerk per clip (Fig. 4.7) and mean jerk per joint over the accepted clips (Fig. 4.9)."""
    clips = [(r, c) for r in records for c in r.data_clips]
    per_clip = [
        {
            "id": c.clip_id,
            "status": c.qc_status,
            "href": f"{PAGES_DIR}/{quote(r.take_id)}.html#{quote(c.clip_id)}",
            "raw": _sig(c.metrics.get("jerk_raw", math.nan), 3),
            "proc": _sig(c.metrics.get("jerk", math.nan), 3),
        }
        for r, c in clips
    ]
    accepted = [c for _, c in clips if c.qc_status == "accepted"]
    over = accepted or [c for _, c in clips]

    def mean(key: str) -> float | None:
        values = [c.metrics.get(key, math.nan) for c in over]
        finite = [v for v in values if math.isfinite(v)]
        return _sig(float(np.mean(finite)), 3) if finite else None

    return {
        "page": "index",
        "clips": per_clip,
        "joints": list(joints),
        "joint_raw": [mean(f"jerk_raw/{j}") for j in joints],
        "joint_proc": [mean(f"jerk/{j}") for j in joints],
        "joint_over": f"{len(over)} accepted clips" if accepted else f"{len(over)} clips",
    }


def _index_page(out: Path, info: store.DatasetInfo, records: Sequence[store.TakeRecord]) -> str:
    data = _jerk_data(records, info.joints)
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
# Take page: data


def _load_clip(out: Path, take_id: str, clip_id: str) -> Clip | str:
    """The clip's arrays, or why they cannot be read."""
    path = store.clip_npz(out, take_id, clip_id)
    try:
        with np.load(path, allow_pickle=False) as data:
            clip = Clip.from_arrays({k: data[k] for k in data.files})
    except (OSError, ValueError, InputError) as exc:
        return f"cannot read {path.name}: {exc}"
    return clip if len(clip.times) and len(clip.timestamps) else f"{path.name} has no frames"


def _repaired_per_joint(clip: Clip, joints: Sequence[str]) -> np.ndarray:
    """`(T, 11)` frames where the repair changed a keypoint the angle is computed from."""
    idx = COCO17.index
    rep = np.asarray(clip.repaired, dtype=bool)
    cols = [rep[:, [idx[k] for k in (*_SHOULDERS, *NEEDS.get(j, ()))]].any(axis=1) for j in joints]
    return np.stack(cols, axis=1) if cols else np.zeros((len(rep), 0), bool)


def _clip_series(clip: Clip, joints: Sequence[str]) -> dict[str, Any]:
    """The angles of one clip (with frames) in degrees on source time, thinned to PLOT_RATE_HZ,
    with the masked spans (`mask`, 100 Hz) and repaired frames (`repaired`, video frames) per
    joint."""
    t0 = clip.start_s
    times, ts = np.asarray(clip.times), np.asarray(clip.timestamps)
    hop = float(np.median(np.diff(times))) if len(times) > 1 else 0.01
    k = _stride(len(times), clip.duration_s)
    kr = _stride(len(ts), float(ts[-1] - ts[0]))
    proc = np.degrees(np.asarray(clip.angles, dtype=np.float64)[::k])
    raw = np.degrees(np.asarray(clip.raw_angles, dtype=np.float64)[::kr])
    known = np.asarray(clip.mask, dtype=bool)
    repaired = _repaired_per_joint(clip, joints)
    ends = frame_ends(ts) + t0
    start, end = t0 + float(times[0]), max(t0 + float(times[-1]) + hop, float(ends[-1]))
    return {
        "t0": round(start, 3),
        "t1": round(end, 3),
        "proc": {
            "t0": round(start, 4),
            "dt": round(k * hop, 6),
            "v": [_steps(col, 0.1) for col in proc.T],
        },
        "raw": {"t": _steps(ts[::kr] + t0, 0.001), "v": [_steps(col, 0.1) for col in raw.T]},
        "masked": [_runs(~known[:, j], times + t0, times + t0 + hop) for j in range(len(joints))],
        "repaired": [_runs(repaired[:, j], ts + t0, ends) for j in range(len(joints))],
    }


def _choices(tracking: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The main-speaker choices of the tracking report (none when it has none)."""
    found = tracking.get("choices") if isinstance(tracking, Mapping) else None
    out = []
    for c in found if isinstance(found, list) else []:
        try:
            t0, t1 = float(c["start_s"]), float(c["end_s"])
            scores = {
                str(track): {str(t): _sig(v, 3) for t, v in terms.items()}
                for track, terms in (c.get("scores") or {}).items()
            }
            if not (math.isfinite(t0) and math.isfinite(t1)):
                continue
            out.append(
                {
                    "t0": round(t0, 3),
                    "t1": round(t1, 3),
                    "main": int(c["main_id"]),
                    "runner": None if c.get("runner_up") is None else int(c["runner_up"]),
                    "shot": c.get("shot"),
                    "reason": str(c.get("reason", "")),
                    "scores": scores,
                }
            )
        except (KeyError, TypeError, ValueError, AttributeError):
            continue  # a report from an older or newer tracker: show what can be read
    return out


def _total(choice: Mapping[str, Any], track: int | None) -> str:
    if track is None:
        return "–"
    total = choice["scores"].get(str(track), {}).get("total")
    return "–" if total is None else f"{total:.3g}"


def _speakers(choices: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    out = []
    for c in choices:
        who = "nobody" if c["main"] < 0 else f"#{c['main']}"
        vs = "" if c["runner"] is None else f" (runner-up #{c['runner']})"
        tip = (
            f"{c['t0']}–{c['t1']} s: main speaker {who} (total {_total(c, c['main'])}), "
            f"runner-up {'none' if c['runner'] is None else '#' + str(c['runner'])} "
            f"(total {_total(c, c['runner'])}); shot {c['shot']}, starts: {c['reason']}"
        )
        out.append({"t0": c["t0"], "t1": c["t1"], "main": c["main"], "label": who + vs, "tip": tip})
    return out


def _cuts(choices: Sequence[Mapping[str, Any]]) -> list[float]:
    """Shot cuts: where the choices' shot number changes."""
    return [b["t0"] for a, b in itertools.pairwise(choices) if a["shot"] != b["shot"]]


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from a JPEG's frame header, without decoding the image."""
    i = 2
    while i + 9 < len(data) and data[i] == 0xFF:
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):  # start of frame
            height = int.from_bytes(data[i + 5 : i + 7], "big")
            return int.from_bytes(data[i + 7 : i + 9], "big"), height
        i += 2 + int.from_bytes(data[i + 2 : i + 4], "big")
    return None


def _preview_frame(
    t: float,
    x0: float,
    size: tuple[float, float],
    record: store.TakeRecord,
    clips: Mapping[str, Clip | str],
) -> dict[str, Any]:
    """The main speaker's COCO-17 keypoints on one preview frame, in strip pixels, from the
    clip whose span holds `t` (none in a dropped span: `note` says why)."""
    part = next((c for c in _parts(record) if c.start_s - 1e-6 <= t < c.end_s), None)
    frame: dict[str, Any] = {"t": round(t, 3), "points": None, "repaired": None}
    if part is None:
        return {**frame, "note": "outside every clip and span"}
    if part.kind == "span":
        return {**frame, "note": f"{_kind(part)}: {'; '.join(part.qc_reasons) or 'no reason'}"}
    clip = clips.get(part.clip_id, "not loaded")
    if not isinstance(clip, Clip):
        return {**frame, "note": f"{part.clip_id}: {clip}"}
    k = int(np.argmin(np.abs(clip.pose2d.timestamps + clip.start_s - t)))
    xy = to_coco17(clip.pose2d.keypoints[k : k + 1], clip.pose2d.skeleton)[0, :, :2]
    width, height = clip.pose2d.image_size
    sx, sy = size[0] / width, size[1] / height
    seen = np.asarray(clip.valid[k], dtype=bool) & np.isfinite(xy).all(axis=1)
    points = [
        [round(x0 + float(x) * sx, 1), round(float(y) * sy, 1)] if ok else None
        for (x, y), ok in zip(xy.tolist(), seen.tolist(), strict=True)
    ]
    return {
        **frame,
        "points": points,
        "repaired": [int(b) for b in np.asarray(clip.repaired[k], dtype=bool)],
        "note": f"{_kind(part)} clip {part.clip_id}",
    }


def _preview(
    out: Path, record: store.TakeRecord, clips: Mapping[str, Clip | str]
) -> dict[str, Any] | None:
    """The preview strip inlined, with a skeleton per frame (None when the take has none)."""
    try:
        jpeg = (store.take_dir(out, record.take_id) / store.PREVIEW).read_bytes()
    except OSError:
        return None
    size = _jpeg_size(jpeg)
    if size is None:
        return None
    w, h = size
    fw = w / max(1, len(record.preview_times))
    return {
        "src": "data:image/jpeg;base64," + base64.b64encode(jpeg).decode(),
        "w": w,
        "h": h,
        "fw": fw,
        "frames": [
            _preview_frame(t, i * fw, (fw, h), record, clips)
            for i, t in enumerate(record.preview_times)
        ],
    }


def _take_data(
    out: Path,
    record: store.TakeRecord,
    info: store.DatasetInfo,
    clips: Mapping[str, Clip | str],
    choices: Sequence[Mapping[str, Any]],
) -> dict[str, Any]:
    """What the page's script draws: timeline, preview with skeletons, each clip's angles."""
    parts = _parts(record)
    t0 = min((c.start_s for c in parts), default=0.0)
    t1 = max((c.end_s for c in parts), default=record.seconds)
    segments = [
        {
            "id": c.clip_id,
            "kind": _kind(c),
            "t0": round(c.start_s, 3),
            "t1": round(c.end_s, 3),
            "reasons": list(c.qc_reasons),
        }
        for c in parts
    ]
    idx = COCO17.index
    return {
        "page": "take",
        "timeline": {
            "t0": round(min(t0, 0.0), 3),
            "t1": round(max(t1, t0 + 1e-3), 3),
            "segments": segments,
            "cuts": _cuts(choices),
            "speakers": _speakers(choices),
            "preview": [round(t, 3) for t in record.preview_times],
        },
        "preview": _preview(out, record, clips),
        "keypoints": list(COCO17.joints),
        "bones": [[idx[a], idx[b], int("left" in a + b)] for a, b in COCO17_BONES],
        "joints": list(info.joints),
        "lower": [round(math.degrees(info.limits[j]["lower"]), 2) for j in info.joints],
        "upper": [round(math.degrees(info.limits[j]["upper"]), 2) for j in info.joints],
        "clips": [
            _clip_series(clip, info.joints)
            for clip in (clips[c.clip_id] for c in record.data_clips)
            if isinstance(clip, Clip)
        ],
    }


# --------------------------------------------------------------------------------------------------
# Take page: HTML


def _facts(record: store.TakeRecord) -> str:
    fps = f"{record.video_fps:.2f} fps" if math.isfinite(record.video_fps) else "fps unknown"
    items = [
        f"subject <b>{_e(record.subject)}</b>",
        f"source {_e(record.source)}",
        f"detector {_e(record.detector or '–')}, lifter {_e(record.lifter or '–')}, {fps}",
        f"{record.seconds:.1f} s looked at, speaker visible {record.visible_s:.1f} s, "
        f"usable {record.usable_s:.1f} s (kept {_kept_share(record):.0%})",
    ]
    return "<p>" + " · ".join(items) + "</p>"


def _segment_list(record: store.TakeRecord) -> str:
    items = []
    for c in _parts(record):
        kind = _kind(c)
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
    if checks.fails(key, value, qc):
        failed.append("over the max" if checks.THRESHOLDS[key][1] == "max" else "under the min")
    if any(checks.is_outlier_reason(key, r) for r in reasons):
        failed.append("outlier")
    if failed:
        return "✗ " + ", ".join(failed)
    checked = checks.threshold(key, qc) is not None or key in qc.outlier_metrics
    return "✓" if checked and value is not None and math.isfinite(value) else ""


def _metrics_table(metrics: Mapping[str, float], reasons: Sequence[str], qc: QCConfig) -> str:
    """The clip's metrics (not the per-joint ones), each beside its threshold; the rows of the
    checks it failed are marked (class 'fail', ✗)."""
    shown = {k for k, *_ in _METRICS}
    rows_of = [(k, label, fmt, scale) for k, label, fmt, scale in _METRICS if k in metrics]
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
    kind = _kind(c)
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


def _take_page(out: Path, record: store.TakeRecord, info: store.DatasetInfo, key: str) -> str:
    clips = {c.clip_id: _load_clip(out, record.take_id, c.clip_id) for c in record.data_clips}
    choices = _choices(record.tracking)
    data = _take_data(out, record, info, clips, choices)
    body = [
        "<p><a href='../index.html'>← all takes</a></p>",
        f"<h1>{_e(record.take_id)}</h1>",
        _facts(record),
        f"<p class='failed'>The take failed: {_e(record.failed)}</p>" if record.failed else "",
        "<h2>Timeline</h2>",
        "<div id='timeline'></div>",
        f"<p class='note'>{_tag('kept')} {_tag('rejected')} {_tag('dropped')} dashed lines: "
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


# --------------------------------------------------------------------------------------------------
# Pages kept when unchanged


def _stat(path: Path) -> tuple[int, int] | None:
    try:
        s = path.stat()
    except OSError:
        return None
    return s.st_size, s.st_mtime_ns


def _page_key(out: Path, record: store.TakeRecord, info: store.DatasetInfo, code: str) -> str:
    """What a take page shows depends on: this module, the record, the clips' files, the
    preview, the robot's limits and the QC thresholds."""
    folder = store.take_dir(out, record.take_id)
    parts = [
        code,
        json.dumps(record.to_json_dict(), sort_keys=True),
        json.dumps([info.joints, info.limits], sort_keys=True),
        info.config.qc.model_dump_json(),  # the thresholds beside the metrics
        _stat(folder / store.PREVIEW),
        [_stat(store.clip_npz(out, record.take_id, c.clip_id)) for c in record.data_clips],
    ]
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:20]


def _existing_key(page: Path) -> str | None:
    try:
        with open(page, encoding="utf-8") as f:
            head = f.read(200)
    except OSError:
        return None
    found = _KEY.search(head)
    return found.group(1) if found else None


def _write_if_changed(path: Path, text: str) -> bool:
    data = text.encode("utf-8")
    try:
        if path.read_bytes() == data:
            return False
    except OSError:
        pass
    write_bytes_atomic(path, data)
    return True


def _render(out: Path, record: store.TakeRecord, info: store.DatasetInfo, key: str) -> str:
    """The take's page; one that cannot be drawn says why (and is tried again next time)."""
    try:
        return _take_page(out, record, info, key)
    except Exception as exc:  # one odd take must not cost the dashboard of every other
        log.warning("%s: cannot draw its QC page (%s)", record.take_id, exc, exc_info=True)
        body = f"<h1>{_e(record.take_id)}</h1><p class='failed'>Page not drawn: {_e(exc)}</p>"
        return _page(f"QC {record.take_id}", body, {"page": "error"})


def write_dashboard(out: Path) -> Path:
    """Write OUT/qc/index.html and OUT/qc/takes/<take_id>.html from the dataset's records and
    clips as they are; returns the index. Only pages whose take changed are rendered (and the
    index only rewritten when it changed); pages of takes no longer in the dataset go."""
    out = Path(out)
    info = store.read_dataset_json(out)
    records = store.take_records(out)
    pages = out / QC_DIR / PAGES_DIR
    pages.mkdir(parents=True, exist_ok=True)
    code = hashlib.sha256((Path(__file__).read_text() + _STYLE + _SCRIPT).encode()).hexdigest()
    wanted = set()
    for record in records:
        page = pages / f"{record.take_id}.html"
        wanted.add(page.name)
        key = _page_key(out, record, info, code)
        if _existing_key(page) != key:
            write_bytes_atomic(page, _render(out, record, info, key).encode("utf-8"))
    for page in pages.glob("*.html"):
        if page.name not in wanted:
            page.unlink(missing_ok=True)
    index = out / QC_DIR / "index.html"
    _write_if_changed(index, _index_page(out, info, records))
    return index
