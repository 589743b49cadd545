"""Speed of extraction: our mediapipe detector vs a bare mediapipe loop, and video hashing.

Both detectors see the same decoded frames (held in memory, so decoding is not measured) in the
same run, alternating, several rounds; the table shows the median frames/s and the ratio.
Usage: python benchmarks/extract.py [--rounds 3] [--samples DIR]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from gesturebank.config import DetectorConfig
from gesturebank.extract.cache import video_digest
from gesturebank.extract.detectors import DETECTORS
from gesturebank.extract.video import iter_frames


def bare_mediapipe(frames: list[tuple[float, np.ndarray]]) -> int:
    """The loop a user would write by hand; returns the number of frames with a pose."""
    from mediapipe.python.solutions import pose as mp_pose

    found = 0
    with mp_pose.Pose(
        static_image_mode=False,
        model_complexity=1,
        smooth_landmarks=True,
        enable_segmentation=False,
        min_detection_confidence=0.5,
        min_tracking_confidence=0.5,
    ) as pose:
        for _, image in frames:
            found += pose.process(image).pose_landmarks is not None
    return found


def ours(frames: list[tuple[float, np.ndarray]]) -> int:
    pose = DETECTORS.create("mediapipe", DetectorConfig()).detect(iter(frames))
    return int(np.isfinite(pose.keypoints[..., 0]).any(axis=1).sum())


def fps_of(fn, frames, rounds: int) -> tuple[float, int]:
    speeds, found = [], 0
    for _ in range(rounds):
        t0 = time.perf_counter()
        found = fn(frames)
        speeds.append(len(frames) / (time.perf_counter() - t0))
    return statistics.median(speeds), found


def detector_table(samples: Path, rounds: int) -> None:
    videos = {
        "pose2sim cam01": samples / "pose2sim" / "Demo_SinglePerson" / "videos" / "cam01.mp4",
        "sports2d demo": samples / "sports2d" / "Demo" / "demo.mp4",
    }
    print(
        f"{'video':<16} {'frames':>6} {'bare fps':>9} {'ours fps':>9} {'ours/bare':>9}"
        f" {'overhead':>9} {'found b/o':>10}"
    )
    for label, path in videos.items():
        frames = list(iter_frames(path))
        bare_mediapipe(frames[:5])  # warm the import and the TFLite delegate
        # Alternate rounds so both share any thermal / background drift.
        b_speeds, o_speeds = [], []
        fb = fo = 0
        for _ in range(rounds):
            s, fb = fps_of(bare_mediapipe, frames, 1)
            b_speeds.append(s)
            s, fo = fps_of(ours, frames, 1)
            o_speeds.append(s)
        b, o = statistics.median(b_speeds), statistics.median(o_speeds)
        print(
            f"{label:<16} {len(frames):>6} {b:>9.1f} {o:>9.1f} {o / b:>9.3f}"
            f" {100 * (b / o - 1):>8.1f}% {fb:>4}/{fo:<4}"
        )


def hash_table(samples: Path) -> None:
    print(f"\n{'file':<28} {'MB':>7} {'sampled ms':>11} {'full sha256 ms':>15}")
    files = [samples / "sports2d" / "Demo" / "demo.mp4"]
    with tempfile.TemporaryDirectory() as tmp:
        big = Path(tmp) / "big.bin"
        with open(big, "wb") as f:
            block = np.random.default_rng(0).bytes(8 << 20)
            for _ in range(64):  # 512 MiB, about 20 min of phone video
                f.write(block)
        files.append(big)
        for path in files:
            path.read_bytes()  # same page-cache state for both (a cold disk favours sampling)
            t0 = time.perf_counter()
            video_digest(path)
            t1 = time.perf_counter()
            h = hashlib.sha256()
            with open(path, "rb") as f:
                for chunk in iter(lambda: f.read(1 << 20), b""):
                    h.update(chunk)
            t2 = time.perf_counter()
            mb = os.path.getsize(path) / 1e6
            print(f"{path.name:<28} {mb:>7.1f} {1e3 * (t1 - t0):>11.2f} {1e3 * (t2 - t1):>15.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--samples", type=Path, default=None)
    args = parser.parse_args()
    if args.samples is None:
        from gesturebank.samples import default_samples_dir

        args.samples = Path(os.environ.get("GESTUREBANK_SAMPLES") or default_samples_dir())
    detector_table(args.samples, args.rounds)
    hash_table(args.samples)


if __name__ == "__main__":
    main()
