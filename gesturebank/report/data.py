"""What the QC dashboard shows, shaped from a dataset: the numbers of the index (time lost per
reason, jerk per clip and per joint) and of a take page (timeline, main-speaker choices, preview
strip with the speaker's skeleton, each clip's angles thinned for plotting), as plain JSON-ready
values. `report.render` writes them into pages; the clips are read through `datasets.store`.
"""

from __future__ import annotations

import base64
import itertools
import math
import re
from collections import Counter, defaultdict
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any
from urllib.parse import quote

import numpy as np

from gesturebank.clip import HEAD_SOURCES, ROLES, Clip
from gesturebank.datasets import store
from gesturebank.datasets.cut import frame_ends
from gesturebank.errors import InputError
from gesturebank.qc.stretches import is_cut_reason
from gesturebank.robot.retarget import NEEDS
from gesturebank.skeletons import COCO17, COCO17_BONES, to_coco17

PAGES_DIR = "takes"  # the take pages, beside the index
PLOT_RATE_HZ = 25.0  # at most this many points per second of a plotted series
_NUMBER = re.compile(r"(?<![\w.])[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?(?![A-Za-z])")
_SHOULDERS = ("left_shoulder", "right_shoulder")  # every angle needs both (retarget.NEEDS)


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


def reason_kind(text: str) -> str:
    """A reason without its numbers and its parenthesis, so that alike reasons add up
    ("head unseen in 95% of the clip (max 50%)" → "head unseen in …% of the clip")."""
    return _NUMBER.sub("…", text.split(" (")[0]).strip()


# --------------------------------------------------------------------------------------------------
# What a take gave


def kind_of(c: store.ClipRecord) -> str:
    """kept | rejected (clips with arrays) | cut (a stretch the QC cut out of a clip, issue 41)
    | dropped | failed (spans)."""
    if c.kind == "clip":
        return "kept" if c.qc_status == "accepted" else "rejected"
    if c.qc_status == "failed":
        return "failed"
    return "cut" if c.qc_reasons and is_cut_reason(c.qc_reasons[0]) else "dropped"


def parts_of(record: store.TakeRecord) -> tuple[store.ClipRecord, ...]:
    """The take's clips and spans; a failed take is one failed span over what was looked at."""
    if record.failed:
        return (
            store.ClipRecord(
                record.take_id, "span", 0.0, record.seconds, "failed", (record.failed,)
            ),
        )
    return tuple(sorted(record.clips, key=lambda c: c.start_s))


def lost_s(c: store.ClipRecord) -> float:
    """Seconds a rejected clip or a dropped span cost."""
    return c.duration_s if c.kind == "clip" else max(0.0, c.end_s - c.start_s)


def time_lost(parts: Iterable[store.ClipRecord]) -> dict[str, tuple[float, Counter[str]]]:
    """Per reason kind, most seconds first: the seconds lost to it and how many parts of each
    kind (rejected, dropped, failed) gave it. A part with two reasons counts under both."""
    seconds: defaultdict[str, float] = defaultdict(float)
    where: defaultdict[str, Counter[str]] = defaultdict(Counter)
    for c in parts:
        kind = kind_of(c)
        if kind == "kept":
            continue
        for reason in c.qc_reasons or ("no reason recorded",):
            seconds[reason_kind(reason)] += lost_s(c)
            where[reason_kind(reason)][kind] += 1
    order = sorted(seconds, key=lambda k: (-seconds[k], k))
    return {k: (seconds[k], where[k]) for k in order}


def kept_share(record: store.TakeRecord) -> float:
    return record.usable_s / record.visible_s if record.visible_s > 0 else 0.0


# --------------------------------------------------------------------------------------------------
# Index: data


def jerk_data(records: Sequence[store.TakeRecord], joints: Sequence[str]) -> dict[str, Any]:
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


# --------------------------------------------------------------------------------------------------
# Take page: data


def load_clip(out: Path, *, take_id: str, clip_id: str) -> Clip | str:
    """The clip's arrays, or why they cannot be read."""
    path = store.clip_npz(out, take_id=take_id, clip_id=clip_id)
    try:
        clip = store.read_clip(path)
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


def speaker_choices(tracking: Mapping[str, Any]) -> list[dict[str, Any]]:
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


def speech_runs(clip: Clip) -> list[list[float]]:
    """[t0, t1] in source seconds of each run of speech in `clip.speech` (each 100 Hz frame
    lasting one hop)."""
    speech = np.asarray(clip.speech, dtype=bool)
    if not len(speech):
        return []
    hop = float(np.median(np.diff(clip.times))) if len(clip.times) > 1 else 0.01
    edges = np.flatnonzero(np.diff(np.concatenate([[0], speech.astype(np.int8), [0]])))
    t = clip.start_s + np.asarray(clip.times, dtype=np.float64)
    return [
        [round(float(t[a]), 3), round(float(t[b - 1] + hop), 3)]
        for a, b in zip(edges[::2], edges[1::2], strict=True)
    ]


def role_runs(clip: Clip) -> list[list[Any]]:
    """[t0, t1, role name] in source seconds of each run of one role in `clip.role`."""
    role = np.asarray(clip.role, dtype=np.int8)
    if not len(role):
        return []
    hop = float(np.median(np.diff(clip.times))) if len(clip.times) > 1 else 0.01
    t = clip.start_s + np.asarray(clip.times, dtype=np.float64)
    starts = np.r_[0, np.flatnonzero(np.diff(role)) + 1]
    stops = np.r_[starts[1:], len(role)]
    return [
        [round(float(t[a]), 3), round(float(t[b - 1] + hop), 3), ROLES[int(role[a])]]
        for a, b in zip(starts, stops, strict=True)
    ]


def head_runs(clip: Clip) -> list[list[Any]]:
    """[t0, t1, source name] in source seconds of each run of one head source in
    `clip.head_source` (per video frame; `clip.HEAD_SOURCES`)."""
    source = np.asarray(clip.head_source, dtype=np.int8)
    if not len(source):
        return []
    t = clip.start_s + np.asarray(clip.timestamps, dtype=np.float64)
    ends = clip.start_s + frame_ends(np.asarray(clip.timestamps, dtype=np.float64))
    starts = np.r_[0, np.flatnonzero(np.diff(source)) + 1]
    stops = np.r_[starts[1:], len(source)]
    return [
        [round(float(t[a]), 3), round(float(ends[b - 1]), 3), HEAD_SOURCES[int(source[a])]]
        for a, b in zip(starts, stops, strict=True)
    ]


def _heads(record: store.TakeRecord, clips: Mapping[str, Clip | str]) -> list[list[Any]]:
    """The head lane: `head_runs` of every loaded clip of the take."""
    loaded = [clips[c.clip_id] for c in record.data_clips]
    return [run for c in loaded if isinstance(c, Clip) for run in head_runs(c)]


def _people(record: store.TakeRecord, clips: Mapping[str, Clip | str]) -> list[dict[str, Any]]:
    """One lane per person with loaded clips: their id and the runs of their roles."""
    lanes: dict[int, list[list[Any]]] = {}
    for c in record.data_clips:
        clip = clips[c.clip_id]
        if isinstance(clip, Clip):
            lanes.setdefault(int(clip.person), []).extend(role_runs(clip))
    return [{"person": k, "runs": runs} for k, runs in sorted(lanes.items())]


def _speech(record: store.TakeRecord, clips: Mapping[str, Clip | str]) -> dict[str, Any]:
    """Where speech was heard (runs, source seconds) within the clips that were loaded
    (`heard`), and the spans it was measured over (`measured`: those clips)."""
    loaded = [clips[c.clip_id] for c in record.data_clips]
    loaded_clips = [c for c in loaded if isinstance(c, Clip)]
    return {
        "measured": [
            [round(c.start_s, 3), round(c.start_s + c.duration_s, 3)] for c in loaded_clips
        ],
        "heard": [run for c in loaded_clips for run in speech_runs(c)],
    }


DEPTH_STEP_S = 0.25  # the depth lane's pieces: the confidence averaged over this many seconds
DEPTH_LEVEL = 0.05  # …and neighbours that round to the same multiple of this merged


def depth_runs(clip: Clip) -> list[list[float]]:
    """[t0, t1, confidence] in source seconds of the clip's depth confidence (`Clip.
    depth_confidence`, per video frame): averaged over `DEPTH_STEP_S`, neighbours that round to
    the same `DEPTH_LEVEL` merged (a steady clip is one piece)."""
    confidence = np.asarray(clip.depth_confidence, dtype=np.float64)
    if not len(confidence):
        return []
    t = clip.start_s + np.asarray(clip.timestamps, dtype=np.float64)
    ends = clip.start_s + frame_ends(np.asarray(clip.timestamps, dtype=np.float64))
    piece = np.floor((t - t[0]) / DEPTH_STEP_S).astype(np.int64)
    runs: list[list[float]] = []
    for k in np.unique(piece):
        pick = piece == k
        level = round(float(np.mean(confidence[pick])) / DEPTH_LEVEL) * DEPTH_LEVEL
        a, b = float(t[pick][0]), float(ends[pick][-1])
        if runs and runs[-1][2] == round(level, 2) and abs(runs[-1][1] - a) < 2e-3:
            runs[-1][1] = round(b, 3)
        else:
            runs.append([round(a, 3), round(b, 3), round(level, 2)])
    return runs


def _depth(record: store.TakeRecord, clips: Mapping[str, Clip | str]) -> list[list[float]]:
    """The depth lane: `depth_runs` of every loaded clip of the take."""
    loaded = [clips[c.clip_id] for c in record.data_clips]
    return [run for c in loaded if isinstance(c, Clip) for run in depth_runs(c)]


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
    part = next((c for c in parts_of(record) if c.start_s - 1e-6 <= t < c.end_s), None)
    frame: dict[str, Any] = {"t": round(t, 3), "points": None, "repaired": None}
    if part is None:
        return {**frame, "note": "outside every clip and span"}
    if part.kind == "span":
        return {**frame, "note": f"{kind_of(part)}: {'; '.join(part.qc_reasons) or 'no reason'}"}
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
        "note": f"{kind_of(part)} clip {part.clip_id}",
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


def take_data(
    out: Path,
    *,
    record: store.TakeRecord,
    info: store.DatasetInfo,
    clips: Mapping[str, Clip | str],
    choices: Sequence[Mapping[str, Any]],
) -> dict[str, Any]:
    """What the page's script draws: timeline, preview with skeletons, each clip's angles."""
    parts = parts_of(record)
    t0 = min((c.start_s for c in parts), default=0.0)
    t1 = max((c.end_s for c in parts), default=record.seconds)
    segments = [
        {
            "id": c.clip_id,
            "kind": kind_of(c),
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
            "speech": _speech(record, clips),
            "depth": _depth(record, clips),
            "head": _heads(record, clips),
            "people": _people(record, clips),
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
