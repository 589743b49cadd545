"""Scaling out: one long video, detected in one pass or in chunks, on the local pool or on Ray.

The take is `footage.LECTURE` (10 minutes, 30 fps, 360 px high, made from the sample media
and kept in the samples' footage folder). Each row builds it into a fresh folder with the
detection cache off (chunks are always computed afresh: OUT_DIR is new):

- pool, one pass:  build.chunk_s = none, so the take is one task on one worker (the baseline)
- pool, chunked:   build.chunk_s = 120 on 2 workers
- Ray, one pass:   build.chunk_s = none on a private Ray with every core, started before the
                   clock starts (as a running cluster): one task, one CPU, one thread
- Ray, chunked:    build.chunk_s = 120 there: Ray's own overhead vs the pool, and what chunks
                   give a cluster

"angles vs one pass" is the mean difference of the clips' 100 Hz angles against the baseline's
(the chunks' stitch tolerance). The estimate scales the chunked pool's per-core rate (video
seconds per wall second per core) to 100 video-hours on 10 and 100 nodes of `--node-cores`
cores, with Ray's measured overhead; node-hours = nodes × wall.

    .venv/bin/python benchmarks/scale.py [--minutes 10] [--chunk-s 120] [--node-cores 2] [--quick]

--quick: 30 s of the lecture at 5 frames a second in 12 s chunks (every row, small), both Ray
rows on one Ray start.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank import footage
from gesturebank.app.build import build_dataset
from gesturebank.config import Config
from gesturebank.datasets import store
from gesturebank.datasets.takes import discover_takes
from gesturebank.samples import default_samples_dir, fetch_samples


def make_lecture(root: Path, minutes: float) -> Path:
    """A videos folder holding the lecture, `minutes` long."""
    samples = default_samples_dir()
    fetch_samples(samples)
    half = minutes * 30.0
    made = samples.parent / "footage" / f"lecture{minutes:g}min.mp4"
    footage.make_take(replace(footage.LECTURE, seconds=(half, half)), samples=samples, out=made)
    videos = root / "videos"
    (videos / "talk").mkdir(parents=True)
    (videos / "talk" / "lecture.mp4").symlink_to(made)
    return videos


def run(videos: Path, out: Path, settings: dict[str, object]) -> dict[str, float]:
    config = Config.model_validate(settings)
    start = time.perf_counter()
    done = [start]
    summary = build_dataset(
        discover_takes(videos),
        videos_dir=videos,
        out=out,
        config=config,
        on_result=lambda _: done.append(time.perf_counter()),
    )
    assert not summary.failed, summary.failed
    (built,) = summary.results
    return {"wall_s": done[-1] - start, "video_s": built.video_s, "clips": built.clips}


def angle_difference_deg(a: Path, b: Path) -> float:
    """Mean |Δ angle| (°) over the clips both datasets have, where both know the angle."""
    da, db = store.Dataset(a), store.Dataset(b)
    diffs = []
    for clip_id in set(da.clip_ids(None)) & set(db.clip_ids(None)):
        x, y = da.load(clip_id), db.load(clip_id)
        if x.angles.shape == y.angles.shape:
            diffs.append(np.abs(x.angles - y.angles)[x.mask & y.mask])
    return float(np.degrees(np.concatenate(diffs).mean())) if diffs else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0, help="lecture length (10)")
    parser.add_argument("--chunk-s", type=float, default=120.0, help="build.chunk_s (120)")
    parser.add_argument("--node-cores", type=int, default=2, help="cores of a node (2)")
    parser.add_argument("--quick", action="store_true", help="30 s, 5 fps, 12 s chunks")
    args = parser.parse_args()
    minutes, chunk_s = (0.5, 12.0) if args.quick else (args.minutes, args.chunk_s)
    video = {"max_fps": 5.0} if args.quick else {}
    cores = os.cpu_count() or 1
    rows = {
        "pool, one pass": {"build": {"chunk_s": None, "workers": 1}},
        "pool, chunked": {"build": {"chunk_s": chunk_s, "workers": cores}},
        # a take's Ray task reserves 1 CPU and runs 1 thread: a long video is one core's work
        "Ray, one pass": {"build": {"chunk_s": None, "executor": "ray"}},
        "Ray, chunked": {"build": {"chunk_s": chunk_s, "executor": "ray"}},
    }
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        videos = make_lecture(root, minutes)
        results = {}
        for name, settings in rows.items():
            settings["build"] |= {"cache_detections": False}  # type: ignore[operator]
            out = root / name.replace(", ", "-").replace(" ", "_")
            if name.startswith("Ray"):
                import ray

                # a running cluster, as users have: its start is not the build's time
                if not ray.is_initialized():
                    ray.init(address="local", include_dashboard=False, log_to_driver=False)
            try:
                results[name] = run(videos, out, {"video": video, **settings})
            finally:
                # --quick: the Ray rows share one start (the last one stops it)
                if name.startswith("Ray") and (name == "Ray, chunked" or not args.quick):
                    ray.shutdown()
            results[name]["out"] = out  # type: ignore[assignment]
        base = results["pool, one pass"]
        table = Table(
            title=f"one {base['video_s'] / 60:.1f}-minute take, {cores} cores, "
            f"build.chunk_s = {chunk_s:g} (detection cache off)"
        )
        for col in ("run", "wall s", "video s / wall s", "speed-up", "angles vs one pass", "clips"):
            table.add_column(col, justify="right")
        for name, r in results.items():
            table.add_row(
                name,
                f"{r['wall_s']:.1f}",
                f"{r['video_s'] / r['wall_s']:.2f}",
                f"{base['wall_s'] / r['wall_s']:.2f}×",
                "" if r is base else f"{angle_difference_deg(base['out'], r['out']):.2f}°",  # type: ignore[arg-type]
                str(int(r["clips"])),
            )
    console = Console(width=150)
    console.print(table)
    pool, ray = results["pool, chunked"], results["Ray, chunked"]
    overhead = ray["wall_s"] / pool["wall_s"] - 1
    console.print(
        "chunks on Ray: "
        f"{results['Ray, one pass']['wall_s'] / ray['wall_s']:.2f}× the speed of one task a take"
    )
    per_core = pool["video_s"] / pool["wall_s"] / cores  # video s per wall s per core
    console.print(
        f"Ray's overhead: {100 * overhead:+.1f} % of the pool's wall time; per core: "
        f"{per_core:.3f} video s / wall s"
    )
    estimate = Table(title=f"100 video-hours on nodes of {args.node_cores} cores")
    for col in ("nodes", "wall hours", "node-hours"):
        estimate.add_column(col, justify="right")
    for nodes in (10, 100):
        wall_h = 100 / (per_core * args.node_cores * nodes) * (1 + max(overhead, 0.0))
        estimate.add_row(str(nodes), f"{wall_h:.1f}", f"{wall_h * nodes:.0f}")
    console.print(estimate)


if __name__ == "__main__":
    main()
