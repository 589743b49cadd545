"""Speed and accuracy of `pepper_angles` (COCO-17 3D joints → Pepper's 11 angles).

Prints two tables:
1. frames/s of the vectorised `pepper_angles` on N frames against a baseline in the same run: the
   same function called once per frame in a Python loop (on a subset), and the speed-up ratio.
2. round-trip error per joint (mean / max, degrees) of random angles inside the limits → Pepper FK
   (ideal chain and real URDF offsets) → `pepper_angles` with the same chain (retarget.kinematics),
   and the offset-free chain on the real robot's poses, outside the documented singular set.

Run: .venv/bin/python benchmarks/retarget.py [--frames 100000] [--loop-frames 2000] [--quick]

--quick: a few thousand frames and poses, one repeat (well under a second of work), to check that
the script runs; it replaces the sizes given on the command line.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.config import RetargetConfig
from gesturebank.robot import pepper
from gesturebank.robot.retarget import pepper_angles


def _random_angles(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 11) uniform inside pepper-1.8 limits, elbow bent > 12°, upper arm > 12° off lateral
    (roll < 73°: the URDF's 15 mm elbow offset turns the upper arm 4.7° further out)."""
    p = pepper.load_profile("pepper-1.8")
    a = rng.uniform(p.lower, p.upper, size=(3 * n, 11))
    ok = (np.abs(a[:, [4, 8]]).min(axis=1) > np.deg2rad(12)) & (
        np.abs(a[:, [2, 6]]).max(axis=1) < np.deg2rad(73)
    )
    return a[ok][:n]


def _best_time(fn, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def speed(frames: int, loop_frames: int, repeats: int) -> Table:
    rng = np.random.default_rng(0)
    p = pepper.load_profile()
    joints = pepper.fk_coco17(rng.uniform(p.lower, p.upper, (frames, 11))).astype(np.float32)
    subset = joints[:loop_frames]

    def loop() -> None:
        for k in range(len(subset)):
            pepper_angles(subset[k : k + 1])

    t_vec = _best_time(lambda: pepper_angles(joints), repeats)
    t_loop = _best_time(loop, 1)
    fps_vec, fps_loop = frames / t_vec, loop_frames / t_loop
    table = Table(title=f"pepper_angles speed (best of {repeats})")
    for col in ("variant", "frames", "time (ms)", "frames/s", "ratio"):
        table.add_column(col, justify="right" if col != "variant" else "left")
    table.add_row(
        "vectorised (T, 17, 3)",
        f"{frames:,}",
        f"{t_vec * 1e3:.1f}",
        f"{fps_vec:,.0f}",
        f"{fps_vec / fps_loop:.0f}×",
    )
    table.add_row(
        "baseline: per-frame Python loop",
        f"{loop_frames:,}",
        f"{t_loop * 1e3:.1f}",
        f"{fps_loop:,.0f}",
        "1×",
    )
    return table


def _elbow_angles(joints: np.ndarray) -> np.ndarray:
    """(N, 2) angle (rad) between upper arm and forearm, left and right, of COCO-17 joints."""
    out = []
    for s, e, w in ((5, 7, 9), (6, 8, 10)):
        u, v = joints[:, e] - joints[:, s], joints[:, w] - joints[:, e]
        out.append(np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), np.sum(u * v, axis=1)))
    return np.stack(out, axis=1)


def accuracy(n: int) -> Table:
    a = _random_angles(np.random.default_rng(1), n)
    table = Table(title=f"round-trip error, degrees ({len(a):,} random poses in the limits)")
    table.add_column("joint")
    runs = {"ideal": ("ideal", "ideal"), "urdf": ("urdf", "urdf"), "urdf/ideal": ("urdf", "ideal")}
    errs, joints = {}, {}
    for name, (fk_model, chain) in runs.items():
        joints[fk_model] = pepper.fk_coco17(a, model=fk_model)
        got = pepper_angles(joints[fk_model], config=RetargetConfig(kinematics=chain))
        errs[name] = np.rad2deg(np.abs((got.astype(np.float64) - a + np.pi) % (2 * np.pi) - np.pi))
    # urdf*: outside the urdf chain's looks-straight band (elbow angle < 2 × 10.1°, see retarget).
    far = _elbow_angles(joints["urdf"]).min(axis=1) > np.deg2rad(22)
    errs["urdf*"] = errs["urdf"][far]
    for name in ("ideal", "urdf", "urdf*", "urdf/ideal"):
        table.add_column(f"{name} mean", justify="right")
        table.add_column(f"{name} max", justify="right")
    for i, joint in enumerate(pepper.JOINTS):
        cells = []
        for name in ("ideal", "urdf", "urdf*", "urdf/ideal"):
            cells += [f"{errs[name][:, i].mean():.3f}", f"{errs[name][:, i].max():.3f}"]
        table.add_row(joint, *cells)
    table.caption = (
        "FK model = chain inverted; urdf/ideal: the offset-free chain on the robot's poses; "
        f"urdf*: the {far.sum():,} poses with both elbow angles > 22°"
    )
    return table


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=100_000)
    ap.add_argument("--loop-frames", type=int, default=2_000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--poses", type=int, default=20_000)
    ap.add_argument("--quick", action="store_true", help="small sizes, one repeat")
    args = ap.parse_args()
    if args.quick:
        args.frames, args.loop_frames, args.repeats, args.poses = 2_000, 200, 1, 2_000
    console = Console(width=120)
    console.print(speed(args.frames, args.loop_frames, args.repeats))
    console.print(accuracy(args.poses))


if __name__ == "__main__":
    main()
