"""The QC dashboard: static HTML pages that work offline (DESIGN.md "Dataset on disk").

    OUT/qc/index.html           sortable table of takes (status, reasons, metrics); jerk per take
                                (as Fig. 4.7) and per joint (Fig. 4.9); spectra before/after the
                                low-pass (Fig. 4.10)
    OUT/qc/takes/<id>.html      why a take was rejected; its metrics; raw vs processed angles with
                                the robot's limits (Fig. 4.11); its spectra and jerk per joint;
                                video frames with the 2D skeleton; 3D skeleton views

Plots are matplotlib figures embedded as PNG data URIs; the only script is a few lines sorting
the table. A Content-Security-Policy forbids every network request. Degrees in all plots.
"""

from __future__ import annotations

import base64
import hashlib
import html
import io
import json
import logging
import multiprocessing
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from gesturebank.config import SplitsConfig
from gesturebank.datasets import store
from gesturebank.fileio import write_bytes_atomic
from gesturebank.qc.checks import QCConfig, dataset_profile, run_qc
from gesturebank.qc.metrics import spectrum, uniform
from gesturebank.robot.pepper import JOINTS, RobotProfile
from gesturebank.skeletons import COCO17, COCO17_BONES, to_coco17

log = logging.getLogger(__name__)

QC_DIR = "qc"
_CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'"
_STATUS_COLOUR = {"accepted": "#2e7d32", "rejected": "#c62828", "failed": "#6d4c41"}
# Metrics shown in the table: (key, header, format, scale).
_COLUMNS = (
    ("duration_s", "duration s", "{:.2f}", 1.0),
    ("jerk_raw", "raw jerk rad²/s⁵", "{:.3g}", 1.0),
    ("jerk", "jerk rad²/s⁵", "{:.3g}", 1.0),
    ("missing_keypoints_fraction", "missing %", "{:.0f}", 100.0),
    ("keypoint_gap_s", "gap s", "{:.2f}", 1.0),
    ("bone_cv_max", "bone CV %", "{:.0f}", 100.0),
    ("swap_events", "swaps", "{:.0f}", 1.0),
    ("spike_max", "spike", "{:.2f}", 1.0),
    ("frozen_fraction", "frozen %", "{:.0f}", 100.0),
    ("jitter_fraction", "jitter %", "{:.0f}", 100.0),
    ("limit_frames_fraction", "at limit %", "{:.0f}", 100.0),
    ("motion_range", "motion °", "{:.0f}", float(np.degrees(1.0))),
)
_STYLE = """
body{font-family:system-ui,sans-serif;margin:1.5em;color:#222}
table{border-collapse:collapse;font-size:13px}
th,td{border:1px solid #ccc;padding:3px 6px;text-align:right}
th{background:#eee;cursor:pointer}
td.l,th.l{text-align:left}
.status{font-weight:bold}
.banner{padding:.6em 1em;border-radius:4px;color:#fff;margin:.5em 0}
img{max-width:100%}
figure{display:inline-block;margin:.5em}
"""
_SORT_JS = """
document.querySelectorAll('table.sortable th').forEach(function(th, col){
  th.addEventListener('click', function(){
    var body = th.closest('table').tBodies[0];
    var rows = Array.prototype.slice.call(body.rows);
    var asc = th.dataset.asc !== '1'; th.dataset.asc = asc ? '1' : '0';
    rows.sort(function(a, b){
      var x = a.cells[col].dataset.v || a.cells[col].textContent;
      var y = b.cells[col].dataset.v || b.cells[col].textContent;
      var nx = parseFloat(x), ny = parseFloat(y);
      var c = (isNaN(nx) || isNaN(ny)) ? x.localeCompare(y) : nx - ny;
      return asc ? c : -c;
    });
    rows.forEach(function(r){ body.appendChild(r); });
  });
});
"""


# --------------------------------------------------------------------------------------------------
# HTML helpers


def _png(fig: Figure) -> str:
    """An <img> holding the figure as a PNG data URI."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80, bbox_inches="tight")
    data = base64.b64encode(buf.getvalue()).decode()
    return f'<img alt="plot" src="data:image/png;base64,{data}">'


def _page(title: str, body: str, script: str = "") -> str:
    js = f"<script>{script}</script>" if script else ""
    return (
        "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
        f"<meta http-equiv='Content-Security-Policy' content=\"{_CSP}\">"
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head>"
        f"<body>{body}{js}</body></html>\n"
    )


def _fmt(metrics: Mapping[str, float], key: str, fmt: str, scale: float) -> tuple[str, str]:
    v = metrics.get(key)
    if v is None or not np.isfinite(v):
        return "–", ""
    return fmt.format(v * scale), repr(float(v))


def _banner(status: str, reasons: Sequence[str]) -> str:
    colour = _STATUS_COLOUR.get(status, "#555")
    items = "".join(f"<li>{html.escape(r)}</li>" for r in reasons)
    why = f"<p>Why:</p><ul class='reasons'>{items}</ul>" if reasons else ""
    return (
        f"<div class='banner' style='background:{colour}'>QC status: "
        f"<span class='status'>{html.escape(status)}</span></div>{why}"
    )


# --------------------------------------------------------------------------------------------------
# Plots (degrees)


def _jerk_per_take(records: Sequence[Mapping[str, Any]]) -> Figure:
    """Raw and processed J per take, log scale (as Fig. 4.7)."""
    fig = Figure(figsize=(max(6.0, 0.35 * len(records) + 2), 3.2))
    ax = fig.add_subplot()
    x = np.arange(len(records))
    for off, key, hatch in ((-0.2, "jerk_raw", ""), (0.2, "jerk", "//")):
        vals = [r["metrics"].get(key, np.nan) for r in records]
        cols = [_STATUS_COLOUR.get(r["qc_status"], "#555") for r in records]
        ax.bar(x + off, vals, 0.4, color=cols, hatch=hatch, edgecolor="k", linewidth=0.3)
    ax.set_yscale("log")
    ax.set_xticks(x, [r["take_id"] for r in records], rotation=60, ha="right", fontsize=7)
    ax.set_ylabel("J (rad²/s⁵)")
    ax.set_title("Jerkiness per take, summed over joints (plain: raw, hatched: processed)")
    return fig


def _jerk_per_joint(per_take: Sequence[Mapping[str, float]], title: str) -> Figure:
    """Mean raw and processed J per joint over the given takes (as Fig. 4.9)."""
    fig = Figure(figsize=(7, 3))
    ax = fig.add_subplot()
    x = np.arange(len(JOINTS))
    for off, key in ((-0.2, "jerk_raw"), (0.2, "jerk")):
        vals = [
            np.nanmean([m.get(f"{key}/{j}", np.nan) for m in per_take] or [np.nan]) for j in JOINTS
        ]
        ax.bar(x + off, vals, 0.4, label=key.replace("_", " "))
    ax.set_yscale("log")
    ax.set_xticks(x, JOINTS, rotation=45, ha="right", fontsize=8)
    ax.set_ylabel("J (rad²/s⁵)")
    ax.legend(fontsize=8)
    ax.set_title(title)
    return fig


def _spectra(items: Iterable[tuple[np.ndarray, float, np.ndarray, float]], cutoff: float) -> Figure:
    """Spectra of every joint's angle before (raw) and after the low-pass (as Fig. 4.10).

    items: (raw (N, 11) rad, its rate, processed (M, 11) rad, its rate) per take."""
    fig = Figure(figsize=(9, 3))
    before, after = fig.subplots(1, 2, sharey=True)
    for raw, raw_hz, proc, proc_hz in items:
        for ax, vals, hz in ((before, raw, raw_hz), (after, proc, proc_hz)):
            if len(vals) < 8:
                continue
            f, p = spectrum(np.degrees(vals), hz)
            ax.plot(f[1:], p[1:], linewidth=0.6)
    for ax, name in ((before, "before"), (after, "after")):
        ax.set_yscale("log")
        ax.axvline(cutoff, color="k", linestyle="--", linewidth=0.8)
        ax.set_xlabel("frequency (Hz)")
        ax.set_title(f"{name} low-pass ({cutoff:g} Hz)")
    before.set_ylabel("power (deg²)")
    return fig


def _trajectories(arrays: Mapping[str, np.ndarray], profile: RobotProfile) -> Figure:
    """Every joint: raw angles at the video's timestamps vs processed 100 Hz angles, with the
    robot's limits (as Fig. 4.11)."""
    fig = Figure(figsize=(11, 7))
    axes = fig.subplots(3, 4, sharex=True).ravel()
    raw, ts = arrays.get("raw_angles"), arrays.get("timestamps")
    for j, (ax, name) in enumerate(zip(axes, JOINTS, strict=False)):
        if raw is not None and ts is not None:
            ax.plot(ts, np.degrees(raw[:, j]), color="0.6", linewidth=0.8, label="raw")
        ax.plot(arrays["times"], np.degrees(arrays["angles"][:, j]), color="C0", label="processed")
        for lim in (profile.lower[j], profile.upper[j]):
            ax.axhline(np.degrees(lim), color="C3", linestyle="--", linewidth=0.7)
        ax.set_title(name, fontsize=9)
        ax.tick_params(labelsize=7)
    axes[0].legend(fontsize=7)
    axes[-1].axis("off")
    fig.supxlabel("time (s)", fontsize=9)
    fig.supylabel("angle (°); dashed: robot limits", fontsize=9)
    return fig


def _video_frames(video: Path | None, times: Sequence[float]) -> list[np.ndarray | None]:
    """RGB frames nearest to `times` (None each when the video cannot be read)."""
    if video is None or not video.is_file() or not len(times):
        return [None] * len(times)
    from gesturebank.extract.video import frames_at

    try:
        found: list[np.ndarray | None] = [frame for _, frame in frames_at(video, times)]
    except Exception as exc:  # a broken video must not stop the dashboard
        log.warning("%s: cannot read frames (%s)", video, exc)
        return [None] * len(times)
    return found + [None] * (len(times) - len(found))


THUMB_HEIGHT = 240  # px of each skeleton thumbnail
_LEFT_RGB, _RIGHT_RGB = (0, 229, 255), (255, 145, 0)


def _skeleton_frames(arrays: Mapping[str, np.ndarray], video: Path | None, n: int = 4) -> str:
    """An <img> of `n` evenly spaced frames with the 2D skeleton drawn on the video (or a blank
    canvas), drawn with OpenCV on thumbnails: matplotlib took seconds for full-size frames."""
    import cv2

    kp = to_coco17(arrays["pose2d_keypoints"], str(arrays["pose2d_skeleton"]))
    ts = np.asarray(arrays["pose2d_timestamps"])
    width, height = (max(int(v), 1) for v in np.asarray(arrays["pose2d_image_size"]))
    picks = np.linspace(0, len(ts) - 1, n).round().astype(int) if len(ts) else np.array([], int)
    frames = _video_frames(video, [float(ts[i]) for i in picks])
    scale = THUMB_HEIGHT / height
    size = (max(1, round(width * scale)), THUMB_HEIGHT)
    idx = COCO17.index
    tiles = []
    for i, frame in zip(picks, frames, strict=True):
        tile = (
            cv2.resize(frame, size, interpolation=cv2.INTER_AREA)
            if frame is not None
            else np.full((size[1], size[0], 3), 244, np.uint8)
        )
        xy = kp[i, :, :2] * scale
        for a, b in COCO17_BONES:
            p, q = xy[idx[a]], xy[idx[b]]
            if np.isfinite(p).all() and np.isfinite(q).all():
                colour = _LEFT_RGB if "left" in a + b else _RIGHT_RGB
                cv2.line(
                    tile, (int(p[0]), int(p[1])), (int(q[0]), int(q[1])), colour, 2, cv2.LINE_AA
                )
        for x, y in xy[np.isfinite(xy).all(axis=1)]:
            cv2.circle(tile, (int(x), int(y)), 3, (255, 255, 255), -1, cv2.LINE_AA)
            cv2.circle(tile, (int(x), int(y)), 3, (0, 0, 0), 1, cv2.LINE_AA)
        label = f"t = {ts[i]:.2f} s" + ("" if frame is not None else " (no video)")
        cv2.rectangle(tile, (0, 0), (8 + 9 * len(label), 22), (255, 255, 255), -1)
        cv2.putText(tile, label, (4, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
        tiles.append(tile)
        tiles.append(np.full((size[1], 6, 3), 255, np.uint8))  # gap between thumbnails
    if not tiles:
        return "<p>no frames</p>"
    ok, png = cv2.imencode(".png", cv2.cvtColor(np.hstack(tiles[:-1]), cv2.COLOR_RGB2BGR))
    data = base64.b64encode(png.tobytes()).decode() if ok else ""
    return f'<img alt="2D skeleton on frames" src="data:image/png;base64,{data}">'


def _skeleton_3d(joints: np.ndarray, timestamps: np.ndarray, n: int = 3) -> Figure:
    """`n` evenly spaced 3D poses (COCO-17), seen from the front and a little above."""
    fig = Figure(figsize=(3 * n, 3.2))
    picks = np.linspace(0, len(joints) - 1, n).round().astype(int)
    finite = joints[np.isfinite(joints).all(axis=-1)]
    lo, hi = (finite.min(0), finite.max(0)) if len(finite) else (np.zeros(3) - 1, np.zeros(3) + 1)
    idx = COCO17.index
    for k, i in enumerate(picks):
        ax = fig.add_subplot(1, n, k + 1, projection="3d")
        for a, b in COCO17_BONES:
            p, q = joints[i, idx[a]], joints[i, idx[b]]
            colour = "C0" if "left" in a + b else "C1"
            ax.plot([p[0], q[0]], [p[1], q[1]], [p[2], q[2]], color=colour)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        ax.set_title(f"t = {timestamps[i]:.2f} s", fontsize=8)
        ax.tick_params(labelsize=6)
    return fig


# --------------------------------------------------------------------------------------------------
# Pages


def _table(records: Sequence[Mapping[str, Any]]) -> str:
    head = "".join(
        ["<th class='l'>take</th><th class='l'>subject</th><th class='l'>status</th>"]
        + [f"<th>{html.escape(h)}</th>" for _, h, _, _ in _COLUMNS]
        + ["<th class='l'>reasons</th>"]
    )
    rows = []
    for r in records:
        tid = html.escape(r["take_id"])
        link = f"<a href='takes/{tid}.html'>{tid}</a>" if r["qc_status"] != "failed" else tid
        colour = _STATUS_COLOUR.get(r["qc_status"], "#555")
        cells = [
            f"<td class='l'>{link}</td><td class='l'>{html.escape(r['subject'])}</td>",
            f"<td class='l status' style='color:{colour}'>{html.escape(r['qc_status'])}</td>",
        ]
        for key, _, fmt, scale in _COLUMNS:
            text, value = _fmt(r["metrics"], key, fmt, scale)
            cells.append(f"<td data-v='{value}'>{text}</td>")
        reasons = "; ".join(r["qc_reasons"] or [])
        cells.append(f"<td class='l'>{html.escape(reasons)}</td>")
        rows.append(f"<tr>{''.join(cells)}</tr>")
    return (
        f"<table class='sortable'><thead><tr>{head}</tr></thead>"
        f"<tbody>{''.join(rows)}</tbody></table>"
    )


def _take_page(
    record: Mapping[str, Any],
    arrays: Mapping[str, np.ndarray],
    profile: RobotProfile,
    video: Path | None,
    analysis_hz: float,
    cutoff: float,
) -> str:
    tid = record["take_id"]
    metrics = record["metrics"]
    rows = "".join(
        f"<tr><td class='l'>{html.escape(k)}</td><td>{v:.4g}</td></tr>"
        for k, v in sorted(metrics.items())
        if "/" not in k
    )
    parts = [
        f"<p><a href='../index.html'>← all takes</a></p><h1>{html.escape(tid)}</h1>",
        f"<p>subject {html.escape(record['subject'])}, source {html.escape(record['source'])}</p>",
        _banner(record["qc_status"], record["qc_reasons"] or []),
        "<h2>Angles: raw vs processed, with the robot's limits</h2>",
        _png(_trajectories(arrays, profile)),
    ]
    raw_u = uniform(arrays["raw_angles"], arrays["timestamps"], analysis_hz)
    parts += [
        "<h2>Spectra before / after the low-pass</h2>",
        _png(_spectra([(raw_u, analysis_hz, np.asarray(arrays["angles"]), 100.0)], cutoff)),
        "<h2>Jerkiness per joint</h2>",
        _png(_jerk_per_joint([metrics], "J per joint (Eq. 3.21)")),
    ]
    if "pose2d_keypoints" in arrays:
        where = "video" if video is not None and video.is_file() else "blank canvas (no video)"
        parts += [f"<h2>2D skeleton on the {where}</h2>", _skeleton_frames(arrays, video)]
    if "pose3d_joints" in arrays:
        parts += [
            "<h2>3D skeleton</h2>",
            _png(_skeleton_3d(np.asarray(arrays["pose3d_joints"]), arrays["pose3d_timestamps"])),
        ]
    parts += ["<h2>Metrics</h2>", f"<table>{rows}</table>"]
    return _page(f"QC {tid}", "".join(parts))


def _video_path(info: Mapping[str, Any], dataset_dir: Path, source: str) -> Path | None:
    if not source:
        return None
    for root in (info.get("videos_dir"), dataset_dir):
        if root and (Path(root) / source).is_file():
            return Path(root) / source
    return None


def _page_key(
    record: Mapping[str, Any], npz: Path, video: Path | None, c: QCConfig, cutoff: float
) -> str:
    """What a take page shows depends on: its record, its arrays, its video and two settings."""
    stat = npz.stat()
    parts = [json.dumps(record, sort_keys=True), stat.st_size, stat.st_mtime_ns, str(video)]
    parts += [c.analysis_rate_hz, cutoff]
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:16]


def _existing_key(page: Path) -> str | None:
    try:
        with open(page, encoding="utf-8") as f:
            head = f.read(200)
    except OSError:
        return None
    found = re.search(r"<!-- page-key (\w+) -->", head)
    return found.group(1) if found else None


def _render_page(
    out: Path,
    record: Mapping[str, Any],
    video: Path | None,
    analysis_hz: float,
    cutoff: float,
    page: Path,
    key: str,
) -> None:
    arrays = store.Dataset(out).load(record["take_id"])
    html_text = _take_page(record, arrays, dataset_profile(out), video, analysis_hz, cutoff)
    html_text = html_text.replace("\n", f"\n<!-- page-key {key} -->\n", 1)
    write_bytes_atomic(page, html_text.encode("utf-8"))


def _render_pages(jobs: list[tuple[Any, ...]], workers: int | None) -> None:
    """Take pages in parallel (matplotlib takes about a second a page)."""
    n = min(workers or os.cpu_count() or 1, len(jobs))
    if n <= 1:
        for job in jobs:
            _render_page(*job)
        return
    ctx = multiprocessing.get_context("forkserver")
    with ProcessPoolExecutor(max_workers=n, mp_context=ctx) as pool:
        for future in [pool.submit(_render_page, *job) for job in jobs]:
            future.result()


def write_dashboard(
    dataset_dir: str | Path, config: QCConfig | None = None, workers: int | None = None
) -> Path:
    """Write OUT/qc/index.html and OUT/qc/takes/<id>.html for the dataset folder; returns the
    index path. Reads the records as they are (run `run_qc` first to refresh the verdicts).
    Pages of takes that did not change since the last call are kept; the others are rendered
    by `workers` processes (default: CPU cores)."""
    c = config or QCConfig()
    out = Path(dataset_dir)
    dataset = store.Dataset(out)
    cutoff = float(dataset.info.get("config", {}).get("processing", {}).get("cutoff_hz", 4.0))
    records = sorted(dataset.records(), key=lambda r: r["take_id"])
    qc_dir = out / QC_DIR
    (qc_dir / "takes").mkdir(parents=True, exist_ok=True)

    spectra_items = []
    jobs = []
    for record in records:
        if record["qc_status"] == "failed":
            continue
        arrays = dataset.load(record["take_id"])
        raw_u = uniform(arrays["raw_angles"], arrays["timestamps"], c.analysis_rate_hz)
        spectra_items.append((raw_u, c.analysis_rate_hz, np.asarray(arrays["angles"]), 100.0))
        video = _video_path(dataset.info, out, record["source"])
        page = qc_dir / "takes" / f"{record['take_id']}.html"
        key = _page_key(record, store.take_npz(out, record["take_id"]), video, c, cutoff)
        if _existing_key(page) != key:  # unchanged takes keep their page: resumed builds are fast
            jobs.append((out, record, video, c.analysis_rate_hz, cutoff, page, key))
    _render_pages(jobs, workers)

    built = [r for r in records if r["qc_status"] != "failed"]
    accepted = [r["metrics"] for r in built if r["qc_status"] == "accepted"]
    counts = {s: sum(r["qc_status"] == s for r in records) for s in store.STATUSES}
    summary = ", ".join(f"{n} {s}" for s, n in counts.items())
    body = [
        "<h1>gesturebank QC</h1>",
        f"<p>{html.escape(str(out))}: {len(records)} takes — {summary}. "
        "Click a column header to sort; click a take for its page.</p>",
        _table(records),
    ]
    if built:
        body += [
            "<h2>Jerkiness per take</h2>",
            _png(_jerk_per_take(built)),
            "<h2>Jerkiness per joint</h2>",
            _png(
                _jerk_per_joint(
                    accepted or [r["metrics"] for r in built],
                    "mean J per joint over the accepted takes"
                    if accepted
                    else "mean J per joint (no accepted take: all built takes)",
                )
            ),
            "<h2>Spectra of every joint of every take</h2>",
            _png(_spectra(spectra_items, cutoff)),
        ]
    index = qc_dir / "index.html"
    index.write_text(_page("gesturebank QC", "".join(body), _SORT_JS), encoding="utf-8")
    (qc_dir / "qc.json").write_text(
        json.dumps(
            {r["take_id"]: [r["qc_status"], r["qc_reasons"] or []] for r in records}, indent=1
        ),
        encoding="utf-8",
    )
    return index


def qc_command(
    out_dir: str | Path,
    config: QCConfig | None = None,
    workers: int | None = None,
    splits: SplitsConfig | None = None,
) -> Path:
    """`gesturebank qc OUT_DIR`: re-run the checks on a built dataset (records, manifest,
    dataset.json counts, splits) and write the dashboard; returns OUT/qc/index.html."""
    run_qc(Path(out_dir), config, splits)
    return write_dashboard(out_dir, config, workers)
