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

    .venv/bin/python benchmarks/yield.py [--quick] [--out DIR]

--quick: three of the takes, at half their length.
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

from gesturebank.app.build import build_dataset, dashboard_after_build
from gesturebank.config import Config
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.takes import discover_takes
from gesturebank.footage import make_footage
from gesturebank.qc.metrics import frozen_fraction, spike_sizes, swap_events
from gesturebank.samples import default_samples_dir, fetch_samples
from gesturebank.skeletons import to_coco17

ROUND1 = "0b95a83"  # the last commit that judged whole videos
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short takes, three of them")
    ap.add_argument("--out", type=Path, help="work folder (kept; default: a temporary one)")
    args = ap.parse_args()
    tmp = None if args.out else tempfile.TemporaryDirectory()
    root = Path(args.out or tmp.name)  # type: ignore[union-attr]
    root.mkdir(parents=True, exist_ok=True)
    videos = footage(root, args.quick)
    out = root / "clips-out"
    start = time.perf_counter()
    summary = dashboard_after_build(build_dataset(discover_takes(videos), videos, out, Config()))
    build_s = time.perf_counter() - start
    old = round1(videos, root)
    kept = kept_checks(out)
    max_spike = Config().qc.max_spike

    table = Table(
        title=f"usable seconds: clips vs the round-1 whole-take rule ({build_s:.0f} s build)"
    )
    for col in ("take", "visible s", "clips: usable s", "share", "clips kept", "round 1: usable s"):
        table.add_column(col, justify="right")
    for col in ("max spike (sw)", "swaps", "frozen"):
        table.add_column(col, justify="right")
    total_visible = total_usable = total_old = 0.0
    for record in summary.takes:
        status, duration = old.get(record.take_id, ("missing", 0.0))
        old_usable = duration if status == "accepted" else 0.0
        spike, swaps, frozen = kept.get(record.take_id, (0.0, 0.0, 0.0))
        share = record.usable_s / record.visible_s if record.visible_s else 0.0
        kept_clips = sum(c.qc_status == "accepted" for c in record.data_clips)
        table.add_row(
            record.take_id,
            f"{record.visible_s:.1f}",
            f"{record.usable_s:.1f}",
            f"{share:.0%}",
            f"{kept_clips}/{len(record.data_clips)}",
            f"{old_usable:.1f} ({status})",
            f"{spike:.2f}{' !' if spike > max_spike else ''}",
            f"{swaps:.0f}",
            f"{frozen:.1%}",
        )
        total_visible += record.visible_s
        total_usable += record.usable_s
        total_old += old_usable
    table.add_row(
        "all",
        f"{total_visible:.1f}",
        f"{total_usable:.1f}",
        f"{total_usable / max(total_visible, 1e-9):.0%}",
        "",
        f"{total_old:.1f} ({total_old / max(total_visible, 1e-9):.0%})",
        "",
        "",
        "",
    )
    Console(width=160).print(table)
    for record in summary.takes:
        lost = sorted({r for c in record.clips if c.qc_status != "accepted" for r in c.qc_reasons})
        if lost:
            print(f"{record.take_id}: " + "; ".join(lost))
    if tmp is not None:
        tmp.cleanup()


if __name__ == "__main__":
    main()
