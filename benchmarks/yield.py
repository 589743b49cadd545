"""Usable seconds of real footage: clips (this code) vs the round-1 whole-take rule, same run.

Footage: the kinds of takes users bring, made from the sample media by
`gesturebank.footage` (a 60 s take of one person, the same motion at 60 and 30 fps, a
waist-up crop, a hard cut to another camera, a second person crossing, a low-resolution copy,
a lab scene with two people), each with real speech; made once and cached.

- **clips**: `build_dataset` with the default config. Per take: the seconds in which the main
  speaker was visible, the usable seconds (accepted clips), their share.
- **round 1**: the same videos through the round-1 code itself (commit ROUND1, exported with
  `git archive` and run in a subprocess): a take counts whole or not at all.
- **kept**: what the accepted clips contain, recomputed from the stored arrays (not from the
  manifest): the largest one-frame jump of a seen keypoint (shoulder widths; the QC limit is
  `qc.max_spike`), left/right swap events, and the share of exactly repeated frames.
- **before / after** (issue 41): the build judged clips whole (`qc.stretch_rounds = 0`, the
  rule before); the same folder re-judged with the defaults (`gesturebank qc`, which cuts as the
  build does) cuts the clips around the stretches that fail. Per take: seconds kept before and
  after, seconds cut out and why (by reason, the numbers left out).
- **motion capture**: every 30 s window of `test.bvh`, `test2.bvh`, `test3.bvh` as a
  motion-capture take of its own (its measured 3D, looped sample speech). QC is tuned on
  test.bvh only; test2 and test3 are reported, never tuned on.
- **renders** (`--renders`): `test.bvh` 31–51 s (issue 30's acceptance stretch) and the held-out
  `test2.bvh` 0–20 s and `test3.bvh` 20–40 s rendered by `gesturebank.synth` (cached by
  checksum) level at 0°, 30°, 60° and from above at 0° (elevation 9.6°), built with BlazePose
  and the default lifter.

    .venv/bin/python benchmarks/yield.py [--quick] [--renders] [--no-round1] [--out DIR]

--quick: three of the takes, at half their length (and test.bvh alone of the mocap).
"""

from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.app.build import BuildSummary, build_dataset, dashboard_after_build
from gesturebank.config import Config
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets import store
from gesturebank.datasets.takes import discover_takes
from gesturebank.footage import make_footage
from gesturebank.qc.metrics import frozen_fraction, spike_sizes, swap_events
from gesturebank.samples import default_samples_dir, fetch_samples
from gesturebank.skeletons import to_coco17

ROUND1 = "0b95a83"  # the last commit that judged whole videos
BVHS = ("test", "test2", "test3")  # motion-capture takes; QC is tuned on test.bvh only
# (motion, start s) of the rendered takes, 20 s each; test2 and test3 are held out
RENDERS = (("test", 31.0), ("test2", 0.0), ("test3", 20.0))
VIEWS = ((0.0, 0.0), (30.0, 0.0), (60.0, 0.0), (0.0, 9.6))  # (azimuth, elevation) degrees
WINDOW_S = 30.0
REPO = Path(__file__).resolve().parents[1]
QUICK = ("fps30", "cut", "crossing")


def footage(root: Path, quick: bool) -> Path:
    """The footage as a videos folder (one subject folder per take, so subjects differ)."""
    samples = default_samples_dir()
    fetch_samples(samples)
    scale = 0.5 if quick else 1.0
    cache = samples.parent / "footage" / f"scale{scale:g}"
    made = make_footage(samples, cache, time_scale=scale, names=QUICK if quick else None)
    videos = root / "videos"
    for name, path in made.items():
        if quick and name not in QUICK:
            continue
        (videos / name).mkdir(parents=True, exist_ok=True)
        (videos / name / path.name).symlink_to(path)
    return videos


def mocap_takes(videos: Path, quick: bool) -> None:
    """Every 30 s window of test.bvh, test2.bvh, test3.bvh (test.bvh alone with `quick`; the
    last, shorter window when it lasts 15 s) as a motion-capture take of its own under
    `videos`, each with the sample speech looped over its length beside it."""
    from dataclasses import replace

    from scipy.io import wavfile

    from gesturebank.footage import SPEECH, SPEECH_RATE, looped_speech
    from gesturebank.mocap.bvh import read_bvh, write_bvh

    samples = default_samples_dir()
    for name in BVHS[:1] if quick else BVHS:
        motion = read_bvh(samples / "bvhtools" / "testBvhFiles" / f"{name}.bvh")
        per_window = round(WINDOW_S / motion.frame_time)
        for a in range(0, len(motion.values), per_window):
            part = motion.values[a : a + per_window]
            if len(part) < per_window / 2:
                break
            start = a * motion.frame_time
            folder = videos / f"mocap_{name}_{start:03.0f}s"
            folder.mkdir(parents=True, exist_ok=True)
            write_bvh(folder / f"{name}.bvh", replace(motion, values=part))
            audio = looped_speech([samples / s for s in SPEECH], seconds=WINDOW_S + 1.0)
            wavfile.write(folder / f"{name}.wav", SPEECH_RATE, (audio * 32767).astype(np.int16))


def rendered_takes(videos: Path) -> None:
    """The renders (`RENDERS` × `VIEWS`, cached), each a subject folder under `videos`."""
    from gesturebank.config import SynthConfig
    from gesturebank.footage import SPEECH
    from gesturebank.synth.take import Performer, cached_render, render_cache

    samples = default_samples_dir()
    for name, start in RENDERS:
        for azimuth, elevation in VIEWS:
            synth = SynthConfig.model_validate(
                {"azimuths_deg": [azimuth], "elevation_deg": elevation, "start_s": start,
                 "length_s": 20.0}
            )  # fmt: skip
            truth = cached_render(
                [Performer(samples / "bvhtools" / "testBvhFiles" / f"{name}.bvh")],
                config=synth,
                mocap=Config().mocap,
                speech=[samples / s for s in SPEECH],
                cache=render_cache(samples),
            )
            up = "_up" if elevation else ""
            folder = videos / f"render_{name}_{start:g}s_{azimuth:g}deg{up}"
            folder.mkdir(parents=True, exist_ok=True)
            for f in truth.videos[0].parent.iterdir():
                if f.suffix in (".mp4", ".wav", ".mkv"):
                    (folder / f.name).symlink_to(f)


def cut_reasons(records: list[store.TakeRecord]) -> dict[str, dict[str, float]]:
    """Per take: seconds cut out by the QC per reason kind (the numbers left out)."""
    from gesturebank.qc.stretches import is_cut_reason
    from gesturebank.report.data import reason_kind

    out: dict[str, dict[str, float]] = {}
    for r in records:
        why = out.setdefault(r.take_id, {})
        for c in r.clips:
            if c.kind == "span" and c.qc_reasons and is_cut_reason(c.qc_reasons[0]):
                kind = reason_kind(c.qc_reasons[0])
                why[kind] = why.get(kind, 0.0) + c.end_s - c.start_s
    return out


def round1(videos: Path, root: Path) -> dict[str, tuple[str, float]]:
    """(qc_status, duration_s) per take id, from the round-1 code's own build."""
    import pyarrow.parquet as pq

    code = root / "round1"
    code.mkdir()
    tar = subprocess.run(
        ["git", "-C", str(REPO), "archive", ROUND1, "gesturebank"], capture_output=True, check=True
    ).stdout
    tarfile.open(fileobj=io.BytesIO(tar)).extractall(code, filter="data")
    out = root / "round1-out"
    env = {**os.environ, "PYTHONPATH": str(code)}
    cmd = [sys.executable, "-m", "gesturebank.cli", "build-dataset", str(videos), str(out), "-q"]
    subprocess.run(cmd, env=env, cwd=root, check=False, capture_output=True)
    rows = pq.read_table(out / "manifest.parquet").to_pylist()
    return {r["take_id"]: (r["qc_status"], float(r["duration_s"] or 0.0)) for r in rows}


def kept_checks(out: Path) -> dict[str, tuple[float, float, float]]:
    """Per take: (largest spike, swap events, frozen share) over its accepted clips' seen
    keypoints, recomputed from the arrays."""
    ds = open_dataset(out)
    found: dict[str, list[tuple[float, float, float]]] = {}
    for row in ds.clips("accepted"):
        clip = ds.load(row.clip.clip_id)
        xy = to_coco17(clip.pose2d.keypoints, clip.pose2d.skeleton)[..., :2].astype(float)
        seen = np.where(clip.valid[..., None], xy, np.nan)
        joints = np.where(clip.valid[..., None], clip.pose3d.joints, np.nan)
        spike = max(float(np.nanmax(spike_sizes(p), initial=0.0)) for p in (seen, joints))
        swaps = float(max(swap_events(seen), swap_events(joints)))
        frozen = max(frozen_fraction(seen), frozen_fraction(joints))
        found.setdefault(row.take.take_id, []).append((spike, swaps, frozen))
    return {t: tuple(max(v[i] for v in vals) for i in range(3)) for t, vals in found.items()}  # type: ignore[misc]


def judged(videos: Path, root: Path) -> tuple[dict[str, store.TakeRecord], Path, float]:
    """Build `videos` judging clips whole (before: `qc.stretch_rounds` 0) into root/whole,
    then copy it to root/cut and re-judge that with the defaults (after: `gesturebank qc`
    cuts as the build does). (records before by take id, the folder after, build seconds)."""
    import shutil

    from gesturebank.datasets.refresh import refresh

    before_out, out = root / "whole", root / "cut"
    whole = Config.model_validate({"qc": {"stretch_rounds": 0}})
    start = time.perf_counter()
    build_dataset(discover_takes(videos), videos_dir=videos, out=before_out, config=whole)
    build_s = time.perf_counter() - start
    before = {r.take_id: r for r in store.take_records(before_out)}
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(before_out, out)
    refresh(out, Config())
    return before, out, build_s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short takes, three of them")
    ap.add_argument("--renders", action="store_true", help="the rendered takes too (slow once)")
    ap.add_argument("--no-round1", action="store_true", help="skip the round-1 build")
    ap.add_argument("--mocap-only", action="store_true", help="the motion-capture takes only")
    ap.add_argument("--out", type=Path, help="work folder (kept; default: a temporary one)")
    args = ap.parse_args()
    tmp = None if args.out else tempfile.TemporaryDirectory()
    root = Path(args.out or tmp.name)  # type: ignore[union-attr]
    root.mkdir(parents=True, exist_ok=True)
    videos = root / "videos"
    videos.mkdir(parents=True, exist_ok=True)
    if not args.mocap_only:
        footage(root, args.quick)
    real = {p.name for p in videos.iterdir()}
    if args.renders and not args.mocap_only:
        rendered_takes(videos)
    mocap = root / "mocap"  # a dataset of its own: smooth measured motion would move the
    mocap_takes(mocap, args.quick)  # dataset-relative jerk check of the videos' clips
    mocap_before, mocap_out, build_s = judged(mocap, root / "mocap-built")
    before, records, kept = mocap_before, store.take_records(mocap_out), kept_checks(mocap_out)
    summary = dashboard_after_build(BuildSummary(mocap_out))
    if not args.mocap_only:
        video_before, out, video_s = judged(videos, root / "video")
        before.update(video_before)
        summary = dashboard_after_build(BuildSummary(out))
        records = store.take_records(out) + records
        kept.update(kept_checks(out))
        build_s += video_s
    cut = cut_reasons(records)
    old = {} if args.no_round1 or args.mocap_only else round1(real_videos(videos, real, root), root)
    max_spike = Config().qc.max_spike

    table = Table(
        title=f"usable seconds: clips cut around bad stretches vs whole clips ({build_s:.0f} s "
        "build)"
    )
    columns = ("take", "visible s", "before: kept s", "share", "after: kept s", "share",
               "cut s", "clips kept", "round 1: usable s")  # fmt: skip
    for col in columns:
        table.add_column(col, justify="right")
    for col in ("max spike (sw)", "swaps", "frozen"):
        table.add_column(col, justify="right")
    total_visible = total_usable = total_before = total_old = 0.0
    for record in records:
        status, duration = old.get(record.take_id, ("-", 0.0))
        old_usable = duration if status == "accepted" else 0.0
        spike, swaps, frozen = kept.get(record.take_id, (0.0, 0.0, 0.0))
        share = record.usable_s / record.visible_s if record.visible_s else 0.0
        was = before[record.take_id].usable_s if record.take_id in before else 0.0
        was_share = was / record.visible_s if record.visible_s else 0.0
        kept_clips = sum(c.qc_status == "accepted" for c in record.data_clips)
        table.add_row(
            record.take_id,
            f"{record.visible_s:.1f}",
            f"{was:.1f}",
            f"{was_share:.0%}",
            f"{record.usable_s:.1f}",
            f"{share:.0%}",
            f"{sum(cut.get(record.take_id, {}).values()):.1f}",
            f"{kept_clips}/{len(record.data_clips)}",
            f"{old_usable:.1f} ({status})" if status != "-" else "-",
            f"{spike:.2f}{' !' if spike > max_spike else ''}",
            f"{swaps:.0f}",
            f"{frozen:.1%}",
        )
        total_visible += record.visible_s
        total_usable += record.usable_s
        total_before += was
        total_old += old_usable
    table.add_row(
        "all",
        f"{total_visible:.1f}",
        f"{total_before:.1f}",
        f"{total_before / max(total_visible, 1e-9):.0%}",
        f"{total_usable:.1f}",
        f"{total_usable / max(total_visible, 1e-9):.0%}",
        f"{sum(sum(v.values()) for v in cut.values()):.1f}",
        "",
        f"{total_old:.1f}" if old else "-",
        "",
        "",
        "",
    )
    Console(width=200).print(table)
    print("\ncut out (after), seconds by reason:")
    for take_id, why in cut.items():
        if why:
            text = "; ".join(f"{k} {v:.1f} s" for k, v in sorted(why.items(), key=lambda x: -x[1]))
            print(f"  {take_id}: {text}")
    print("\nstill lost (after), whole clips and spans:")
    for record in records:
        lost = sorted(
            {r for c in record.clips if c.qc_status != "accepted" for r in c.qc_reasons
             if not r.startswith("cut: ")}
        )  # fmt: skip
        if lost:
            print(f"  {record.take_id}: " + "; ".join(lost))
    print(f"dashboard: {summary.dashboard}")
    if tmp is not None:
        tmp.cleanup()


def real_videos(videos: Path, real: set[str], root: Path) -> Path:
    """A folder with only the real footage (what round 1 is compared on)."""
    folder = root / "real-videos"
    folder.mkdir(exist_ok=True)
    for name in real:
        if not (folder / name).exists():
            (folder / name).symlink_to((videos / name).resolve())
    return folder


if __name__ == "__main__":
    main()
