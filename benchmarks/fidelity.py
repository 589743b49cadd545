"""Motion fidelity on the real Pose2Sim 4-camera demo: the reference and the monocular lifters.

(a) The multi-view reference against itself: Pepper angles from disjoint camera pairs, and with
    one camera left out against all cameras (per joint, mean/median degrees).
(b) Cross-view reprojection, a yardstick without ground truth: a monocular lifter works from one
    camera; its 3D is put in the world by that camera's calibrated pose and a similarity fit of
    its torso (shoulders, hips) onto the reference's, then its face and arm joints are projected
    into the *other* cameras and compared with their own 2D detections (pixels). The floor is the
    reference's own error on the same keypoints.
(c) Each monocular lifter's Pepper-angle error against the reference (all cameras), and its
    speed (frames/s of lifting alone).
(d) Where (b) and (c) come from: the depth sign of each arm bone. Of the frames where the
    reference's bone points clearly towards or away from the source camera, those where the
    monocular lifter's bone points the other way (a bone tilted towards or away from a camera
    looks the same in its image, so only the lifter's prior decides).

The reference is the `multiview` lifter with the project's config (so `[multiview]` options,
e.g. a refinement, apply). BlazePose 2D on every camera, the demo's own Qualisys calibration,
every frame (60 fps).

    .venv/bin/python benchmarks/fidelity.py [--quick]

--quick: the first 0.3 s, one camera pair split and one monocular camera (seconds).
Acceptance (issue 15): `fitted` beats `blazepose-world` by ≥ 30 % on (b) and (c), every camera.
"""

from __future__ import annotations

import argparse
import time
import warnings
from itertools import combinations

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.config import Config
from gesturebank.datasets.takes import find_calibration
from gesturebank.extract.pipeline import extract_take
from gesturebank.lift import LIFTERS, TakeViews
from gesturebank.lift.multiview.cameras import CameraGroup
from gesturebank.lift.multiview.lifter import MultiviewLifter, match_videos
from gesturebank.poses import Pose2D, Pose3D
from gesturebank.robot.pepper import JOINTS
from gesturebank.robot.retarget import pepper_angles
from gesturebank.samples import default_samples_dir, fetch_samples
from gesturebank.skeletons import COCO17

MONOCULAR = ("blazepose-world", "geometric", "fitted")
QUICK_S = 0.3
TORSO = [COCO17.index[j] for j in ("left_shoulder", "right_shoulder", "left_hip", "right_hip")]
LIMBS = [COCO17.index[j] for j in COCO17.joints[:11] if "shoulder" not in j]  # face, arms
ARM_BONES = {
    f"{side[0].upper()} {part}": (COCO17.index[f"{side}_{a}"], COCO17.index[f"{side}_{b}"])
    for side in ("left", "right")
    for part, (a, b) in (("upper arm", ("shoulder", "elbow")), ("forearm", ("elbow", "wrist")))
}
DEEP = 0.3  # (d): a bone points clearly towards or away when |its unit vector's z| exceeds this
# Output frames → camera axes (x right, y down, z forward).
AXES = {"camera": (1, 1, 1), "blazepose-world": (1, 1, 1), "image-ortho": (1, -1, -1)}


def angle_diff_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N, 11) |a − b| in degrees (periodic), NaN where either is unknown."""
    d = np.abs(a - b)
    return np.rad2deg(np.minimum(d, 2 * np.pi - d))


def mean_median(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    with warnings.catch_warnings():  # a joint never known on both sides is NaN, and says so
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmean(d, axis=0), np.nanmedian(d, axis=0)


def similarity(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Scale, rotation (3, 3), translation (3,) with dst ≈ s R src + t (Umeyama), (N, 3) each."""
    ms, md = src.mean(0), dst.mean(0)
    u, sv, vt = np.linalg.svd((dst - md).T @ (src - ms))
    d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    rot = u @ d @ vt
    scale = float((sv * np.diag(d)).sum() / ((src - ms) ** 2).sum())
    return scale, rot, md - scale * rot @ ms


def cross_view_px(
    pose: Pose3D, source: int, reference: np.ndarray, cams: CameraGroup, poses: list[Pose2D]
) -> np.ndarray:
    """Pixel errors (all other cameras' confident face/arm keypoints) of a monocular pose from
    camera `source`, placed by its camera's pose and a torso similarity fit (module doc)."""
    cam = cams[source]
    local = pose.joints.astype(np.float64) * np.asarray(AXES[pose.frame])
    world = (local - cam.t) @ cam.R  # camera → world
    errors = []
    for t in range(len(world)):
        if not (np.isfinite(world[t, TORSO]).all() and np.isfinite(reference[t, TORSO]).all()):
            continue
        s, rot, tr = similarity(world[t, TORSO], reference[t, TORSO])
        errors.append(_view_errors(s * world[t, LIMBS] @ rot.T + tr, t, source, cams, poses))
    return np.concatenate(errors) if errors else np.array([np.nan])


def depth_sign_errors(
    pose: Pose3D, source: int, reference: np.ndarray, cams: CameraGroup
) -> dict[str, tuple[int, int]]:
    """(d) per arm bone: (frames where the reference bone points clearly towards or away from
    camera `source`, of those the frames where the monocular pose's bone points the other way)."""
    cam = cams[source]
    local = pose.joints.astype(np.float64) * np.asarray(AXES[pose.frame])
    ref = reference @ cam.R.T + cam.t  # world → that camera's axes
    out = {}
    for name, (i, j) in ARM_BONES.items():
        mine, true = local[:, j] - local[:, i], ref[:, j] - ref[:, i]
        with np.errstate(invalid="ignore"):
            z = true[:, 2] / np.linalg.norm(true, axis=1)
            deep = (np.abs(z) > DEEP) & np.isfinite(mine[:, 2])
        out[name] = (int(deep.sum()), int((np.sign(mine[deep, 2]) != np.sign(z[deep])).sum()))
    return out


def _view_errors(
    points: np.ndarray, t: int, source: int | None, cams: CameraGroup, poses: list[Pose2D]
) -> np.ndarray:
    out = []
    for c, (cam, pose) in enumerate(zip(cams, poses, strict=True)):
        if c == source:
            continue
        kp = pose.to_coco17().keypoints[t, LIMBS].astype(np.float64)
        err = np.linalg.norm(cam.project(points) - kp[:, :2], axis=-1)
        out.append(err[(kp[:, 2] >= 0.3) & np.isfinite(err)])
    return np.concatenate(out)


def floor_px(reference: np.ndarray, source: int, cams: CameraGroup, poses: list[Pose2D]) -> float:
    """Median error of the reference itself on the keypoints (b) compares against."""
    errs = [
        _view_errors(reference[t, LIMBS], t, source, cams, poses) for t in range(len(reference))
    ]
    e = np.concatenate(errs)
    return float(np.median(e[np.isfinite(e)]))


def consistency_table(
    poses: list[Pose2D], cams: CameraGroup, config: Config, reference: np.ndarray, quick: bool
) -> Table:
    """(a): disjoint camera pairs against each other, leave-one-out against all cameras."""

    def angles(idx: tuple[int, ...]) -> np.ndarray:
        views = TakeViews.of([poses[i] for i in idx], cams.subset([cams.names[i] for i in idx]))
        lifter = LIFTERS.create("multiview", config)
        return pepper_angles(lifter.lift(views), config=config.retarget)

    rows: list[tuple[str, np.ndarray]] = []
    all_idx = tuple(range(len(cams)))
    splits = [p for p in combinations(all_idx, 2) if 0 in p]  # each split once: pair with cam 0
    for pair in splits[:1] if quick else splits:
        rest = tuple(i for i in all_idx if i not in pair)
        name = f"{'+'.join(cams.names[i] for i in pair)} vs {'+'.join(cams.names[i] for i in rest)}"
        rows.append((name, angle_diff_deg(angles(pair), angles(rest))))
    for left_out in all_idx[:1] if quick else all_idx:
        keep = tuple(i for i in all_idx if i != left_out)
        rows.append(
            (f"all − {cams.names[left_out]} vs all", angle_diff_deg(angles(keep), reference))
        )
    table = Table(title="(a) reference self-consistency, Pepper angles, mean/median degrees")
    for col in ("comparison", *JOINTS, "mean", "median"):
        table.add_column(col, justify="right")
    for name, d in rows:
        mean, med = mean_median(d)
        cells = [f"{a:.0f}/{b:.0f}" for a, b in zip(mean, med, strict=True)]
        table.add_row(name, *cells, f"{np.nanmean(mean):.1f}", f"{np.nanmedian(d):.1f}")
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help=f"the first {QUICK_S} s only")
    args = parser.parse_args()
    samples = default_samples_dir()
    root = samples / "pose2sim" / "Demo_SinglePerson"
    if not (root / "videos").is_dir():  # fetching re-checks every sample's checksum: only if needed
        fetch_samples(samples)
    config = Config.model_validate({"video": {"max_fps": None}})  # the demo's 60 fps
    if args.quick:
        config.video.end_s = QUICK_S
    cams = CameraGroup.load(find_calibration(root))
    videos = match_videos(cams, sorted((root / "videos").glob("*.mp4")))
    poses = [extract_take(v, config, with_audio=False).tracked.pose for v in videos]
    ref_pose, report = MultiviewLifter.from_config(config).lift_with_report(
        TakeViews.of(poses, cams)
    )
    reference = ref_pose.joints.astype(np.float64)
    ref_angles = pepper_angles(ref_pose, config=config.retarget)
    console = Console(width=max(Console().width, 160))  # 14+ columns: keep them readable
    span = f", first {QUICK_S} s" if args.quick else ""
    tri = report.triangulation.error[np.isfinite(report.triangulation.error)]
    refine = getattr(config.multiview, "refine", "n/a")  # the option lands with issue 15 item 1
    print(f"Pose2Sim Demo_SinglePerson, {len(ref_pose)} frames{span}; reference reprojection "
          f"median {np.median(tri):.1f} px (refine: {refine})")  # fmt: skip
    console.print(consistency_table(poses, cams, config, ref_angles, args.quick))

    xview = Table(title="(b) cross-view reprojection of monocular lifters, pixels (other cameras)")
    for col in ("lifter", "camera", "median px", "mean px", "floor px", "frames/s"):
        xview.add_column(col, justify="right")
    angle = Table(title="(c) Pepper-angle error against the reference, mean degrees")
    for col in ("lifter", "camera", *JOINTS, "mean", "median"):
        angle.add_column(col, justify="right")
    signs = Table(title=f"(d) arm bones pointing the wrong way in depth: wrong / deep frames "
                  f"(|unit z| > {DEEP} in the reference)")  # fmt: skip
    for col in ("lifter", "camera", *ARM_BONES, "wrong %"):
        signs.add_column(col, justify="right")
    sources = range(1) if args.quick else range(len(cams))
    for name in MONOCULAR:
        for c in sources:
            lifter = LIFTERS.create(name, config)
            # the view's own calibrated camera (the fitted lifter uses its intrinsics)
            view = TakeViews.of(poses[c], cams.subset([cams.names[c]]))
            start = time.perf_counter()
            pose = lifter.lift(view)
            fps = len(pose) / (time.perf_counter() - start)
            px = cross_view_px(pose, c, reference, cams, poses)
            floor = floor_px(reference, c, cams, poses)
            xview.add_row(name, cams.names[c], f"{np.nanmedian(px):.1f}", f"{np.nanmean(px):.1f}",
                          f"{floor:.1f}", f"{fps:.0f}")  # fmt: skip
            d = angle_diff_deg(pepper_angles(pose, config=config.retarget), ref_angles)
            mean, _ = mean_median(d)
            angle.add_row(name, cams.names[c], *(f"{v:.0f}" for v in mean),
                          f"{np.nanmean(mean):.1f}", f"{np.nanmedian(d):.1f}")  # fmt: skip
            sign = depth_sign_errors(pose, c, reference, cams)
            deep, wrong = (sum(v[k] for v in sign.values()) for k in (0, 1))
            signs.add_row(name, cams.names[c], *(f"{w}/{n}" for n, w in sign.values()),
                          f"{100 * wrong / max(deep, 1):.0f}")  # fmt: skip
    console.print(xview)
    console.print(angle)
    console.print(signs)


if __name__ == "__main__":
    main()
