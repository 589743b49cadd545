"""build-dataset throughput: video-seconds per wall-second with 1 and 2 workers, same clips.

Each configuration builds the same takes into a fresh folder with the detection cache off (so
the detector really runs). "takes wall s" runs until the last take is written; the QC verdicts
and the dashboard, which need all takes, follow and are shown apart. "outside detect" is the
share of per-take time spent outside decode + detection: everything gesturebank adds around it.

The baseline is the loop people write by hand (cv2.VideoCapture → RGB → mediapipe Pose, nothing
else), run over the same clips in 1 and in 2 processes: its 2-vs-1 ratio is what this machine
gives the bare detector. One worker normally uses every core (decoding in a thread, the
interpreters' threads), so "2 vs 1" can only gain what threads leave idle. The row "1 core" is
one worker with one thread of each, confined to one CPU (sched_setaffinity, inherited by its
worker process and threads): what each worker of a pool of N gets on N cores, so "vs 1 core"
shows how the pool itself scales. (Without the confinement its decoding thread runs on the
other core, and that row would be worth more than one core.)

"face model" is the share of the takes' time the face landmark model took with everything
around it (the second decode at speech.mouth_rate_hz, the crops, the mouths and, with
`retarget.head_source = "face"`, the head fits; the take record's `mouth_seconds`). The rows
"head from body" build without the head from the face (issue 40), so the difference is what the
head costs.

    .venv/bin/python benchmarks/build.py [--copies 6] [--quick]

--copies N links each talking demo clip N times (as separate takes) so two workers have work to
share and the ~1 s start-up (imports) is not what gets measured; the clips themselves come from
`gesturebank fetch-samples`. --quick: one clip, one copy, one worker and one process.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.app.build import build_dataset, dashboard_after_build
from gesturebank.config import Config
from gesturebank.datasets.takes import discover_takes
from gesturebank.samples import default_samples_dir, fetch_samples


def make_videos(root: Path, copies: int, quick: bool = False) -> Path:
    samples = default_samples_dir()
    fetch_samples(samples)
    videos = root / "videos"
    clips = sorted((samples / "talking").rglob("*.mp4"))
    for clip in clips[:1] if quick else clips:
        for i in range(copies):
            target = videos / f"{clip.parent.name}{i}" / clip.name
            target.parent.mkdir(parents=True, exist_ok=True)
            target.symlink_to(clip)
    return videos


def run(
    videos: Path, root: Path, workers: int, threads: int | None = None, head: str = "face"
) -> dict[str, float]:
    """Build the takes with `workers` processes; `threads` per worker for decoding and the
    detector's interpreters (None: the default, cores / workers); the head from `head`
    (`retarget.head_source`)."""
    out = root / f"out-{workers}-{threads}-{head}"
    # copies share their content: without the cache each one really runs the detector
    build = {"workers": workers, "cache_detections": False}
    if threads is not None:
        build |= {"decode_threads": threads, "inference_threads": threads}
    config = Config.model_validate({"build": build, "retarget": {"head_source": head}})
    start = time.perf_counter()
    done = [start]
    summary = build_dataset(
        discover_takes(videos),
        videos_dir=videos,
        out=out,
        config=config,
        on_result=lambda _: done.append(time.perf_counter()),
    )
    summary = dashboard_after_build(summary)  # as build-dataset does
    total = time.perf_counter() - start
    wall = done[-1] - start  # until the last take is written; QC and the dashboard follow
    built = [r for r in summary.results if r.outcome == "built"]
    assert len(built) == len(summary.results), summary.failed
    video_s = sum(r.video_s for r in built)
    take_s = sum(r.wall_s for r in built)
    detect_s = sum(r.detect_s for r in built)
    faces_s = sum(
        json.loads(path.read_text())["tracking"].get("mouth_seconds", 0.0)
        for path in (out / "takes").glob("*.json")
    )
    return {
        "takes": len(built),
        "video_s": video_s,
        "wall_s": wall,
        "throughput": video_s / wall,
        "outside": (take_s - detect_s) / take_s,
        "faces": faces_s / take_s,
        "finalise_s": total - wall,
    }


def hand_loop(path: str) -> float:
    """Decode and detect one clip the way a hand-written script does; returns its seconds."""
    import cv2
    from mediapipe.python.solutions import pose as mp_pose

    from gesturebank.extract.detectors.mediapipe import _quiet_startup

    capture = cv2.VideoCapture(path)
    fps = capture.get(cv2.CAP_PROP_FPS)
    frames = 0
    with _quiet_startup():  # only silences the C++ start-up log, as the detector does
        pose = mp_pose.Pose(model_complexity=1)
        pose.process(np.zeros((64, 64, 3), np.uint8))
    with pose:
        while True:
            ok, bgr = capture.read()
            if not ok:
                break
            pose.process(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
            frames += 1
    capture.release()
    return frames / fps


def _one_cpu() -> None:
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})


def run_on_one_core(videos: Path, root: Path) -> dict[str, float] | None:
    """`run` with one worker and one thread, in a fresh process confined to one CPU; None where
    the platform cannot confine a process (no sched_setaffinity)."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    context = multiprocessing.get_context("spawn")  # its own fork server, started confined
    with ProcessPoolExecutor(max_workers=1, mp_context=context, initializer=_one_cpu) as pool:
        return pool.submit(run, videos, root, 1, 1).result()


def run_baseline(videos: Path, processes: int) -> dict[str, float]:
    # the same clips, longest first, as build-dataset schedules them
    paths = sorted((str(p) for p in videos.rglob("*.mp4")), key=lambda p: -Path(p).stat().st_size)
    # spawn: fresh interpreters, like separate scripts (and build-dataset's forkserver, with
    # its preloaded pipeline, stays its own)
    context = multiprocessing.get_context("spawn")
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=processes, mp_context=context) as pool:
        video_s = sum(pool.map(hand_loop, paths))
    wall = time.perf_counter() - start
    return {"takes": len(paths), "video_s": video_s, "wall_s": wall, "throughput": video_s / wall}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--copies", type=int, default=6, help="links per demo clip (default 6)")
    parser.add_argument("--quick", action="store_true", help="one clip, one worker")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        videos = make_videos(root, 1 if args.quick else args.copies, args.quick)
        # interleaved, so a slow spell of the machine does not favour one side
        rows = {}
        for n in (1,) if args.quick else (1, 2):
            rows[("hand loop", n)] = run_baseline(videos, n)
            rows[("build-dataset", n)] = run(videos, root, n)
            if n == 1:
                rows[("build-dataset, head from body", n)] = run(videos, root, n, head="body")
            if n == 1:
                one_core = run_on_one_core(videos, root)  # how the pool itself scales
                if one_core is not None:
                    rows[("build-dataset, 1 core", n)] = one_core
    first = rows[("build-dataset", 1)]
    table = Table(
        title=f"{int(first['takes'])} takes, {first['video_s']:.1f} s of video "
        "(talking demo clips, detection cache off)"
    )
    columns = ["run", "processes", "takes wall s", "video s / wall s", "2 vs 1", "vs 1 core"]
    for col in (*columns, "vs hand loop", "outside detect", "face model", "then QC + dashboard s",
                "of build"):  # fmt: skip
        table.add_column(col, justify="right")
    single = rows.get(("build-dataset, 1 core", 1))
    for (name, n), r in sorted(rows.items()):
        own = rows.get((name, 1))
        hand = rows[("hand loop", n)]["throughput"]
        table.add_row(
            name,
            str(n),
            f"{r['wall_s']:.1f}",
            f"{r['throughput']:.2f}",
            f"{r['throughput'] / own['throughput']:.2f}×" if own else "",
            f"{r['throughput'] / single['throughput']:.2f}×"
            if single and name.startswith("build")
            else "",
            f"{r['throughput'] / hand:.2f}×",
            f"{100 * r['outside']:.1f} %" if "outside" in r else "",
            f"{100 * r['faces']:.1f} %" if "faces" in r else "",
            f"{r['finalise_s']:.1f}" if "finalise_s" in r else "",
            f"{100 * r['finalise_s'] / (r['wall_s'] + r['finalise_s']):.1f} %"
            if "finalise_s" in r
            else "",
        )
    Console(width=170).print(table)


if __name__ == "__main__":
    main()
