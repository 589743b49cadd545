"""Speed, accuracy and reach of `pepper_angles` (COCO-17 3D joints → Pepper's 11 angles).

Prints three tables:
1. frames/s of the vectorised `pepper_angles` on N frames against a baseline in the same run: the
   same function called once per frame in a Python loop (on a subset), and the speed-up ratio.
2. round-trip error per joint (mean / max, degrees) of random angles inside the limits → Pepper FK
   (ideal chain and real URDF offsets) → `pepper_angles` with the same chain (retarget.kinematics),
   and the offset-free chain on the real robot's poses, outside the documented singular set.
3. reach: `[retarget] reach` "clamp" against "soft" (and soft margins, and ElbowYaw at a straight
   elbow held or faded to 0) on real motion beyond Pepper's reach — the first 30 s of the
   bvhtools motion-capture take test.bvh, and each `--dataset` folder's clips (re-retargeted
   from their stored 3D and seen keypoints, e.g. the Pose2Sim 4-camera demo as
   tests/datasets/test_multicamera_pairs.py builds it, or `make demo`'s). Per mode: the share of
   frames with a joint held at a limit (within qc.frozen_limit_tol), the correlation of the
   joints' velocities with the person's unlimited angles (joints beyond reach in ≥ 1 % of the
   frames), the mean robot-space hand (wrist) error against the unlimited pose (Pepper FK), the
   largest step as a multiple of the joint speed, and the time the QC would call frozen.

Run: .venv/bin/python benchmarks/retarget.py [--frames 100000] [--loop-frames 2000]
     [--mocap-s 30] [--dataset OUT_DIR ...] [--quick]

--quick: a few thousand frames and poses, one repeat, 10 s of motion capture (a few seconds of
work), to check that the script runs; it replaces the sizes given on the command line.
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.config import Config, RetargetConfig
from gesturebank.datasets.process import process_angles
from gesturebank.filters import clock
from gesturebank.robot import pepper
from gesturebank.robot.reach import out_of_reach
from gesturebank.robot.retarget import angle_support, pepper_angles


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


@dataclass(frozen=True)
class Motion:
    """One stretch of a person's motion: COCO-17 joints (T, 17, 3) at `timestamps (T,)`, the
    keypoints seen (T, 17), and the 100 Hz clock its angles are processed onto."""

    joints: np.ndarray
    timestamps: np.ndarray
    valid: np.ndarray
    clock: np.ndarray


def mocap_motion(seconds: float) -> Motion:
    """The first `seconds` of the bvhtools sample test.bvh (FreeMoCap, 30 fps)."""
    from gesturebank.mocap.bvh import read_bvh
    from gesturebank.mocap.pose import motion_pose

    samples = Path(os.environ.get("GESTUREBANK_SAMPLES", "~/.cache/gesturebank/samples"))
    motion = read_bvh(samples.expanduser() / "bvhtools/testBvhFiles/test.bvh")
    n = round(seconds / float(np.median(np.diff(motion.times))))
    pose, _ = motion_pose(motion.frames(0, n), config=Config().mocap, source="test.bvh")
    ts = pose.timestamps - pose.timestamps[0]
    return Motion(
        pose.joints, ts, np.isfinite(pose.joints).all(axis=-1), clock(0.0, ts[-1], rate_hz=100)
    )


def dataset_motions(out: Path) -> list[Motion]:
    """Every clip of a built dataset, from its stored 3D pose and seen keypoints."""
    from gesturebank.clip import Clip
    from gesturebank.datasets import store

    motions = []
    for record in store.take_records(out):
        for c in record.data_clips:
            with np.load(store.clip_npz(out, take_id=record.take_id, clip_id=c.clip_id)) as data:
                clip = Clip.from_arrays({k: data[k] for k in data.files})
            motions.append(Motion(clip.pose3d.joints, clip.timestamps, clip.valid, clip.times))
    return motions


def _hands(angles: np.ndarray) -> np.ndarray:
    """(N, 2, 3) Pepper's wrists (m, robot frame) of `angles (N, 11)`."""
    points = pepper.fk(np.nan_to_num(angles))
    return np.stack([points["left_wrist"], points["right_wrist"]], axis=1)


def reach_row(motions: list[Motion], retarget: RetargetConfig, *, free_yaw: str) -> list[float]:
    """[held %, velocity correlation, hand error cm, largest step × joint speed, frozen s,
    beyond reach %] of `motions` processed with `retarget` (module docstring)."""
    config = Config()
    profile = pepper.load_profile(config.robot.profile)
    tol, speed = config.qc.frozen_limit_tol, profile.velocity / config.processing.rate_hz
    held, frames, beyond, err, n_err, steps = 0, 0, 0, 0.0, 0, 0.0
    dv_robot, dv_person = [], []
    for m in motions:
        raw = pepper_angles(m.joints, config=retarget, free_yaw=free_yaw)  # type: ignore[arg-type]
        raw[~angle_support(m.valid)] = np.nan
        p = process_angles(
            raw=raw,
            timestamps=m.timestamps,
            clock=m.clock,
            processing=config.processing,
            retarget=retarget,
            profile=profile,
        )
        a, person, known = p.angles.astype(np.float64), p.unlimited, p.mask
        with np.errstate(invalid="ignore"):
            at = known & ((a <= profile.lower + tol) | (a >= profile.upper - tol))
        held += int(at.any(axis=1).sum())
        beyond += int((out_of_reach(person, profile) & known).any(axis=1).sum())
        frames += len(a)
        rows = known.all(axis=1)
        e = np.linalg.norm(_hands(a[rows]) - _hands(person[rows]), axis=-1)
        err, n_err = err + float(e.sum()), n_err + e.size
        steps = max(steps, float(np.nanmax(np.abs(np.diff(a, axis=0)) / speed)))
        dv_robot.append(np.diff(a, axis=0))
        dv_person.append(np.diff(person, axis=0))
    robot, person = np.concatenate(dv_robot), np.concatenate(dv_person)
    corrs = []
    for j in range(robot.shape[1]):
        ok = np.isfinite(robot[:, j]) & np.isfinite(person[:, j])
        if ok.sum() > 2 and np.std(robot[ok, j]) > 0:
            corrs.append(float(np.corrcoef(robot[ok, j], person[ok, j])[0, 1]))
    return [
        100 * held / frames,
        float(np.mean(corrs)),
        100 * err / max(1, n_err),
        steps,
        100 * beyond / frames,
    ]


def reach(sources: dict[str, list[Motion]]) -> Table:
    table = Table(title="motion beyond reach: \\[retarget] reach clamp vs soft")
    for col in (
        "motion",
        "reach",
        "ElbowYaw at a straight elbow",
        "beyond reach %",
        "held at a limit %",
        "velocity corr.",
        "hand error cm",
        "max step × joint speed",
    ):
        table.add_column(col, justify="left" if col in ("motion", "reach") else "right")
    modes = [
        ("clamp", RetargetConfig(reach="clamp"), "hold"),
        ("clamp", RetargetConfig(reach="clamp"), "fade"),
        *(
            (f"soft {m:g} rad", RetargetConfig(reach="soft", soft_margin=m), "hold")
            for m in (0.25, 0.5, 0.65, 0.75)
        ),
    ]
    for name, motions in sources.items():
        for label, retarget, free_yaw in modes:
            held, corr, err, step, beyond = reach_row(motions, retarget, free_yaw=free_yaw)
            table.add_row(
                name,
                label,
                free_yaw,
                f"{beyond:.0f}",
                f"{held:.1f}",
                f"{corr:.3f}",
                f"{err:.2f}",
                f"{step:.2f}",
            )
    table.caption = (
        "velocity corr.: per joint, of the robot's and the person's 100 Hz steps, mean over joints"
    )
    return table


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=100_000)
    ap.add_argument("--loop-frames", type=int, default=2_000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--poses", type=int, default=20_000)
    ap.add_argument("--mocap-s", type=float, default=30.0, help="seconds of test.bvh measured")
    ap.add_argument("--dataset", type=Path, nargs="*", default=[], help="built dataset folders")
    ap.add_argument("--quick", action="store_true", help="small sizes, one repeat")
    args = ap.parse_args()
    if args.quick:
        args.frames, args.loop_frames, args.repeats, args.poses = 2_000, 200, 1, 2_000
        args.mocap_s = 10.0
    console = Console(width=140)
    console.print(speed(args.frames, args.loop_frames, args.repeats))
    console.print(accuracy(args.poses))
    sources = {f"test.bvh {args.mocap_s:g} s": [mocap_motion(args.mocap_s)]}
    sources |= {str(d): dataset_motions(d) for d in args.dataset}
    console.print(reach(sources))


if __name__ == "__main__":
    main()
