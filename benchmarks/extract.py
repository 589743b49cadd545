"""Speed of the detectors: `blazepose` against the `mediapipe` reference, the cost of each extra
person, and what the 30 fps frame selection saves on 60 fps footage.

Every row compares two things measured in the same run on the same decoded frames (held in
memory, so decoding is not measured), in alternating rounds, median over rounds; the table shows
ratios, not absolute times, so it reads the same on a busy machine.

1. frames/s of `blazepose` ÷ frames/s of `mediapipe` on single-person footage (mediapipe's per
   call graph start-up, ~0.2 s, is part of its time, as in a build).
2. seconds per frame with up to 1, 2, 3 people tracked, in units of one landmark pass (crop +
   model + decoding on one ROI, timed alone in the same run), and what each extra person
   adds (the difference per person found). Three people come from a montage of three
   Demo_SinglePerson cameras side by side.
3. video seconds processed per wall second with every second frame (what `video.max_fps = 30`
   selects from 60 fps footage) ÷ the same with every frame.
4. seconds per frame with `detector.blazepose.small_people` ÷ without, on a frame with a far
   bystander.
5. (not with --quick) the sampled video digest of the detection cache ÷ a full sha256.

    .venv/bin/python benchmarks/extract.py [--rounds 3] [--quick] [--samples DIR]

--quick: a few frames and one round (a few seconds), to check that the script runs.
"""

from __future__ import annotations

import argparse
import hashlib
import itertools
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.config import BlazePoseConfig, MediaPipeConfig, VideoConfig
from gesturebank.extract.detectors import DETECTORS, Frame
from gesturebank.extract.detectors.blazepose import BlazePoseDetector, roi_from_points
from gesturebank.extract.video import iter_frames
from gesturebank.poses import MultiPose2D

Frames = list[Frame]


def decode(path: Path, limit: int | None) -> Frames:
    """The first `limit` (None: all) frames, every one of them (the rows choose their own)."""
    return list(itertools.islice(iter_frames(path, VideoConfig(max_fps=None)), limit))


def seconds(fn: Callable[[], object]) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def alternate(runs: dict[str, Callable[[], object]], rounds: int) -> dict[str, float]:
    """Median wall seconds of each run, the runs interleaved round by round (shared drift)."""
    times: dict[str, list[float]] = {k: [] for k in runs}
    for _ in range(rounds):
        for name, fn in runs.items():
            times[name].append(seconds(fn))
    return {k: statistics.median(v) for k, v in times.items()}


def people(multi: MultiPose2D) -> float:
    return float(multi.present.sum(axis=1).mean())


def single_person(samples: Path, rounds: int, limit: int | None, table: Table) -> None:
    bp = DETECTORS.create("blazepose", BlazePoseConfig())
    mp = DETECTORS.create("mediapipe", MediaPipeConfig())
    videos = {
        "pose2sim cam01 (60 fps)": samples / "pose2sim/Demo_SinglePerson/videos/cam01.mp4",
        "pose2sim cam03 (60 fps)": samples / "pose2sim/Demo_SinglePerson/videos/cam03.mp4",
    }
    for label, path in videos.items():
        frames = decode(path, limit)
        bp.detect_people(iter(frames[:5]))  # warm both interpreters
        t = alternate(
            {
                "mediapipe": lambda f=frames: mp.detect_people(iter(f)),
                "blazepose": lambda f=frames: bp.detect_people(iter(f)),
            },
            rounds,
        )
        table.add_row(
            "blazepose fps ÷ mediapipe fps",
            f"{label}, {len(frames)} frames",
            f"{t['mediapipe'] / t['blazepose']:.2f}",
        )


def montage(*clips: Frames) -> Frames:
    """The clips' frames side by side (heights padded to the tallest), on the first's clock."""
    out = []
    for frames in zip(*clips, strict=False):
        h = max(image.shape[0] for _, image in frames)
        pad = [np.pad(i, ((0, h - i.shape[0]), (0, 0), (0, 0))) for _, i in frames]
        out.append((frames[0][0], np.ascontiguousarray(np.hstack(pad))))
    return out


def landmark_passes(det: BlazePoseDetector, frames: Frames, n: int) -> Callable[[], object]:
    """`n` landmark passes (crop, model, decode) on the person of the first frame."""
    image = frames[0][1]
    d = det.find_people(image)
    roi = roi_from_points(d.keypoints[0, 0], d.keypoints[0, 1])
    det.landmarks(image, roi)  # warm
    return lambda: [det.landmarks(image, roi) for _ in range(n)]


def extra_people(samples: Path, rounds: int, limit: int | None, table: Table) -> None:
    single = [
        decode(samples / f"pose2sim/Demo_SinglePerson/videos/{c}.mp4", limit)
        for c in ("cam01", "cam03", "cam04")
    ]
    clips = {
        "Demo_MultiPerson cam04": decode(
            samples / "pose2sim/Demo_MultiPerson/videos/cam04.mp4", limit
        ),
        "Sports2D demo": decode(samples / "sports2d/Demo/demo.mp4", limit),
        "montage of SinglePerson cam01, 03, 04": montage(*single),
    }
    dets = {n: BlazePoseDetector(BlazePoseConfig(max_people=n)) for n in (1, 2, 3)}
    for label, frames in clips.items():
        seen = {n: people(d.detect_people(iter(frames))) for n, d in dets.items()}  # also warms
        runs = {str(n): (lambda d=d, f=frames: d.detect_people(iter(f))) for n, d in dets.items()}
        runs["pass"] = landmark_passes(dets[1], frames, 20)
        t = alternate(runs, rounds)
        one = t["pass"] / 20
        per_frame = {n: t[str(n)] / len(frames) / one for n in (1, 2, 3)}
        for n in (1, 2, 3):
            if n > 1 and seen[n] < seen[n - 1] + 0.5:
                continue  # not that many people in this clip
            table.add_row(
                f"s/frame ÷ one landmark pass, max_people={n}",
                f"{label}: {seen[n]:.2f} people/frame",
                f"{per_frame[n]:.2f}",
            )
            if n > 1:  # what the target is on: ≤ 1.1 landmark passes per extra person
                extra = (per_frame[n] - per_frame[n - 1]) / (seen[n] - seen[n - 1])
                table.add_row(
                    f"each extra person ÷ one landmark pass, {n - 1} → {n}", label, f"{extra:.2f}"
                )


def half_rate(samples: Path, rounds: int, limit: int | None, table: Table) -> None:
    bp = DETECTORS.create("blazepose", BlazePoseConfig())
    path = samples / "pose2sim/Demo_MultiPerson/videos/cam01.mp4"
    frames = decode(path, limit)
    half = frames[::2]  # what max_fps = 30 keeps of 60 fps
    t = alternate(
        {
            "full": lambda: bp.detect_people(iter(frames)),
            "half": lambda: bp.detect_people(iter(half)),
        },
        rounds,
    )
    table.add_row(
        "video s per wall s: max_fps=30 ÷ every frame",
        f"Demo_MultiPerson cam01 (60 fps, 2 people), {len(frames)} frames",
        f"{t['full'] / t['half']:.2f}",
    )


def small_people(samples: Path, rounds: int, limit: int | None, table: Table) -> None:
    """`detector.blazepose.small_people` against the default views, same frames (it finds the
    bystander)."""
    frames = decode(samples / "pose2sim/Demo_MultiPerson/videos/cam01.mp4", limit)
    dets = {s: BlazePoseDetector(BlazePoseConfig(small_people=s)) for s in (False, True)}
    seen = {s: people(d.detect_people(iter(frames))) for s, d in dets.items()}  # also warms
    t = alternate(
        {str(s): (lambda d=d: d.detect_people(iter(frames))) for s, d in dets.items()}, rounds
    )
    table.add_row(
        "s/frame: small_people ÷ default",
        f"Demo_MultiPerson cam01: {seen[True]:.2f} vs {seen[False]:.2f} people/frame",
        f"{t['True'] / t['False']:.2f}",
    )


def digest(samples: Path, table: Table) -> None:
    from gesturebank.extract.cache import video_digest

    with tempfile.TemporaryDirectory() as tmp:
        big = Path(tmp) / "big.bin"
        with open(big, "wb") as f:
            block = np.random.default_rng(0).bytes(8 << 20)
            for _ in range(64):  # 512 MiB, about 20 min of phone video
                f.write(block)
        for path in (samples / "sports2d/Demo/demo.mp4", big):
            path.read_bytes()  # same page-cache state for both (a cold disk favours sampling)

            def full(p: Path = path) -> None:
                h = hashlib.sha256()
                with open(p, "rb") as f:
                    for chunk in iter(lambda: f.read(1 << 20), b""):
                        h.update(chunk)

            t = alternate({"full": full, "sampled": lambda p=path: video_digest(p)}, 3)
            size = f"{path.stat().st_size / 1e6:.0f} MB"
            table.add_row(
                "full sha256 s ÷ sampled digest s",
                f"{path.name}, {size}",
                f"{t['full'] / t['sampled']:.0f}",
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="few frames, one round")
    parser.add_argument("--samples", type=Path, default=None)
    args = parser.parse_args()
    if args.samples is None:
        from gesturebank.samples import default_samples_dir, fetch_samples

        args.samples = default_samples_dir()
        if not (args.samples / "pose2sim/Demo_MultiPerson/videos/cam04.mp4").is_file():
            fetch_samples(args.samples)
    rounds, limit = (1, 6) if args.quick else (args.rounds, None)
    table = Table(title=f"detector speed ratios ({rounds} round(s), median, same frames)")
    table.add_column("measure")
    table.add_column("footage")
    table.add_column("ratio", justify="right")
    single_person(args.samples, rounds, limit, table)
    extra_people(args.samples, rounds, limit, table)
    half_rate(args.samples, rounds, limit, table)
    small_people(args.samples, rounds, limit, table)
    if not args.quick:
        digest(args.samples, table)
    Console().print(table)


if __name__ == "__main__":
    main()
