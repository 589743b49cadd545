"""build-dataset throughput: video-seconds per wall-second with 1 and 2 workers, same clips.

Each configuration builds the same takes into a fresh folder with the detection cache off (so
the detector really runs). "takes wall s" runs until the last take is written; the QC verdicts
and the dashboard, which need all takes, follow and are shown apart. "outside detect" is the
share of per-take time spent outside decode + detection: everything gesturebank adds around it.

    .venv/bin/python benchmarks/build.py [--copies 3]

--copies N links each talking demo clip N times (as separate takes) so two workers have work to
share; the clips themselves come from `gesturebank fetch-samples`.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

from gesturebank.config import Config
from gesturebank.datasets.build import build_dataset
from gesturebank.datasets.takes import discover_takes
from gesturebank.samples import default_samples_dir, fetch_samples


def make_videos(root: Path, copies: int) -> Path:
    samples = default_samples_dir()
    fetch_samples(samples)
    videos = root / "videos"
    for clip in sorted((samples / "talking").rglob("*.mp4")):
        for i in range(copies):
            target = videos / f"{clip.parent.name}{i}" / clip.name
            target.parent.mkdir(parents=True, exist_ok=True)
            target.symlink_to(clip)
    return videos


def run(videos: Path, root: Path, workers: int) -> dict[str, float]:
    out = root / f"out-{workers}"
    # copies share their content: without the cache each one really runs the detector
    config = Config.model_validate({"build": {"workers": workers, "cache_detections": False}})
    start = time.perf_counter()
    done = [start]
    summary = build_dataset(
        discover_takes(videos),
        videos,
        out,
        config,
        on_result=lambda _: done.append(time.perf_counter()),
    )
    total = time.perf_counter() - start
    wall = done[-1] - start  # until the last take is written; QC and the dashboard follow
    built = [r for r in summary.results if r.outcome == "built"]
    assert len(built) == len(summary.results), summary.failed
    video_s = sum(r.video_s for r in built)
    take_s = sum(r.wall_s for r in built)
    detect_s = sum(r.detect_s for r in built)
    return {
        "takes": len(built),
        "video_s": video_s,
        "wall_s": wall,
        "throughput": video_s / wall,
        "outside": (take_s - detect_s) / take_s,
        "finalise_s": total - wall,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--copies", type=int, default=3, help="links per demo clip (default 3)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        videos = make_videos(root, args.copies)
        rows = {w: run(videos, root, w) for w in (1, 2)}
    table = Table(title="build-dataset on the talking demo clips (detection cache off)")
    columns = ["workers", "takes", "video s", "takes wall s", "video s / wall s", "ratio"]
    for col in (*columns, "outside detect", "then QC + dashboard s"):
        table.add_column(col, justify="right")
    base = rows[1]["throughput"]
    for w, r in rows.items():
        table.add_row(
            str(w),
            str(int(r["takes"])),
            f"{r['video_s']:.1f}",
            f"{r['wall_s']:.1f}",
            f"{r['throughput']:.2f}",
            f"{r['throughput'] / base:.2f}×",
            f"{100 * r['outside']:.1f} %",
            f"{r['finalise_s']:.1f}",
        )
    Console().print(table)


if __name__ == "__main__":
    main()
