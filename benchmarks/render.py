"""Ground-truth renders (`gesturebank.synth`): how fast they are made, and whether BlazePose takes
the figure for a person.

Renders `test.bvh` (bvhtools, the issue's stretch 31–51 s) with one camera 3 m away at chest
height, turned 0°, 30° and 60° from the person's front, and prints:
1. speed: frames rendered per second of wall time and of CPU time (Embree uses every core, so
   CPU time is what a busy machine cannot hide), at 1280×720 and at the tests' 640×360, and as
   a multiple of real time (CPU frames/s over the video's own 30 frames/s);
2. BlazePose on each render: share of frames with the person found, median 2D error of the body
   joints (% of the true torso length), also with each joint's constant offset removed (its
   median error vector: BlazePose's shoulder and hip sit elsewhere than a mocap skeleton's), and
   the share of frames with left and right swapped.

Renders are cached by checksum beside the samples (`synth.take.render_cache`); speed is only
measured on a fresh render (`--fresh` forces one).

Run: .venv/bin/python benchmarks/render.py [--seconds 20] [--looks tshirt sleeves] [--fresh]
    [--quick]

--quick: 1 s at 640×360, 0° only.
"""

from __future__ import annotations

import argparse
import shutil
import time

from rich.console import Console
from rich.table import Table

from gesturebank.config import BlazePoseConfig, MocapConfig, SynthConfig
from gesturebank.extract.detectors import DETECTORS
from gesturebank.extract.video import iter_frames
from gesturebank.footage import SPEECH
from gesturebank.samples import default_samples_dir, fetch_samples
from gesturebank.synth.score import score_2d
from gesturebank.synth.take import Performer, cached_folder, cached_render, render_cache
from gesturebank.testing.mocap import BVH

START_S = 31.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--azimuths", type=float, nargs="+", default=[0.0, 30.0, 60.0])
    parser.add_argument("--looks", nargs="+", default=["tshirt"])
    parser.add_argument("--sizes", nargs="+", default=["1280x720", "640x360"])
    parser.add_argument("--fresh", action="store_true", help="render again even if cached")
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    if args.quick:
        args.seconds, args.azimuths, args.looks, args.sizes = 1.0, [0.0], ["tshirt"], ["640x360"]
    samples = default_samples_dir()
    fetch_samples(samples)
    speech = [samples / rel for rel in SPEECH]
    bvh = samples / BVH
    console = Console()
    speed = Table(title=f"render speed, test.bvh {START_S:g}-{START_S + args.seconds:g} s")
    for col in (
        "size",
        "look",
        "az °",
        "frames",
        "wall s",
        "CPU s",
        "fps wall",
        "fps CPU",
        "× real time",
    ):
        speed.add_column(col, justify="right")
    found = Table(title="BlazePose on the renders (body joints, % of torso length)")
    for col in (
        "size",
        "look",
        "az °",
        "found %",
        "median error %",
        "offset-free %",
        "L/R swapped %",
    ):
        found.add_column(col, justify="right")
    for size in args.sizes:
        w, h = (int(v) for v in size.split("x"))
        for look in args.looks:
            for azimuth in args.azimuths:
                config = SynthConfig(
                    azimuths_deg=[azimuth],
                    width_px=w,
                    height_px=h,
                    start_s=START_S,
                    length_s=args.seconds,
                    look=look,
                )
                performers = [Performer(bvh)]
                cache = render_cache(samples)
                if args.fresh:
                    shutil.rmtree(
                        cached_folder(
                            performers,
                            config=config,
                            mocap=MocapConfig(),
                            speech=speech,
                            cache=cache,
                        ),
                        ignore_errors=True,
                    )
                wall, cpu = time.perf_counter(), time.process_time()
                truth = cached_render(
                    performers, config=config, mocap=MocapConfig(), speech=speech, cache=cache
                )
                wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
                n = len(truth.times)
                if wall > 1.0:  # rendered now, not found in the cache
                    speed.add_row(
                        size,
                        look,
                        f"{azimuth:g}",
                        str(n),
                        f"{wall:.1f}",
                        f"{cpu:.1f}",
                        f"{n / wall:.1f}",
                        f"{n / cpu:.1f}",
                        f"{n / cpu / config.rate_fps:.2f}",  # baseline: the video's own rate
                    )
                video = truth.videos[0]
                detector = DETECTORS.create("blazepose", BlazePoseConfig(), video=video)
                pose = detector.detect(iter_frames(video)).to_coco17()
                s = score_2d(pose.keypoints, truth.joints2d[0])
                found.add_row(
                    size,
                    look,
                    f"{azimuth:g}",
                    f"{100 * s.found:.1f}",
                    f"{s.error_pct:.1f}",
                    f"{s.offset_free_pct:.1f}",
                    f"{100 * s.swapped:.1f}",
                )
    console.print(speed)
    console.print(found)


if __name__ == "__main__":
    main()
