"""The head from the face seen by several calibrated cameras (issue 40, multi-view): rendered
rigs of held-out motion, and the real Pose2Sim demos. Crops, fits and scoring are
`benchmarks/head_views.py`'s.

Calibrated rigs (`--rig N [N ...]`) of N cameras spread over `--spread` degrees around the front,
at each of `--elevations` (`rig_errors`): each camera alone, the mean of the cameras' head
rotations, and the face mesh triangulated across the cameras (`lift.multiview.triangulate`) with
the reference fitted to it; scored in a level frontal camera's axes, over the frames where two or
more cameras kept the face (test3 from 30° above: 12 of 40). The build combines the cameras'
heads (`datasets.head.rig_head`: the "mean rotation" here, each camera's depth direction counted
less); `benchmarks/pipeline_truth.py --cameras N` scores it through the build, and
`benchmarks/head_parts.py --cameras N` splits the build's error into the face's and the torso's.
Held out, 40 frames, 4 cameras: each camera 7.1–9.1°, averaged 4.8–7.7°, triangulated 4.6–6.4°.

`--pose2sim`: real footage. The Pose2Sim demos' face widths and the model's presence per camera,
then, on the multi-person demo, each camera pair's faces of one person (the face pair whose
triangulated mesh reprojects within MATCH_PX): the head from one camera against the triangulated
face's, beside the two cameras' heads' angle between them (their spread).

The floor: `--crop oracle` (no render, no model) triangulates the points the renderer paints, and
the reference fitted to them reads every head 3.8–4.0° off (pitch 4.6–5.3° low): the reference is
the model's reading of a real face and the render is that photo flat on an ellipsoid.

    .venv/bin/python benchmarks/head_rig.py --bvh test2.bvh --frames 40 --rig 3 4 \
        --elevations 0 30 [--keypoints truth|blazepose] [--crop face|oracle]
    .venv/bin/python benchmarks/head_rig.py --pose2sim --frames 30

--quick: the oracle on a 3-camera level rig, 4 frames (no render, no model), to check that the
script runs.
"""

from __future__ import annotations

import argparse
from itertools import combinations
from pathlib import Path

import numpy as np
from head_views import (
    CROP,
    true_heads,
    turned,
    view_camera,
    view_heads,
    yaw_pitch,
)
from rich.console import Console
from rich.table import Table

from gesturebank.camera_files import load_cameras
from gesturebank.config import MocapConfig, MultiviewConfig, SynthConfig, VideoConfig
from gesturebank.extract import head_pose
from gesturebank.extract.detectors.blazepose import BlazePoseDetector
from gesturebank.extract.mouth import CROP_PER_WIDTH, FaceLandmarker
from gesturebank.extract.video import iter_frames, probe
from gesturebank.geometry import Camera, CameraGroup
from gesturebank.lift.multiview.triangulate import triangulate
from gesturebank.samples import default_samples_dir
from gesturebank.synth.take import rig_azimuths, stretch


def rig_errors(
    joints: np.ndarray,
    *,
    azimuths: list[float],
    elevation: float,
    model: FaceLandmarker,
    crop: str,
    gate: float,
    detector: BlazePoseDetector | None = None,
) -> dict[str, np.ndarray]:
    """`--rig`: the head seen by calibrated cameras at `azimuths`, scored in the axes of a level
    camera facing the person (yaw about the vertical, pitch): errors (K, 2) per method over the
    frames where two or more cameras kept the face ("each camera": every camera's own head, the
    monocular baseline; "mean rotation": the chordal mean of the cameras' heads; "triangulated":
    the mesh points triangulated (`lift.multiview.triangulate`, the `multiview` defaults) and the
    reference face fitted to them rigidly, with scale)."""
    cams = CameraGroup([view_camera(joints, azimuth=a, elevation=elevation, name=f"cam{i + 1}")
                        for i, a in enumerate(azimuths)])  # fmt: skip
    seen = [view_heads(joints, camera=c, model=model, crop=crop, gate=gate, detector=detector)
            for c in cams]  # fmt: skip
    level = view_camera(joints, azimuth=0.0, elevation=0.0).R
    truth = true_heads(joints, level)
    world = np.stack(
        [level @ c.R.T @ heads for c, (_, heads, _, _) in zip(cams, seen, strict=True)]
    )
    kept = np.isfinite(world).all(axis=(-2, -1))  # (C, T)
    several = kept.sum(axis=0) >= 2
    each = kept & several
    out = {
        "each camera": turned(
            yaw_pitch(world[each]) - np.broadcast_to(truth, (*each.shape, 2))[each]
        )
    }
    mean = head_pose.orthonormal(np.where(kept[..., None, None], world, 0.0).sum(axis=0))
    out["mean rotation"] = turned(yaw_pitch(mean[several]) - truth[several])
    points = np.stack([p for _, _, p, _ in seen])  # (C, T, 468, 2)
    weight = np.nan_to_num(np.stack([w for _, _, _, w in seen]))
    weight = np.repeat(weight[..., None], points.shape[2], axis=-1)
    mv = MultiviewConfig()
    tri = triangulate(points, weight, cameras=cams, min_confidence=gate,
                      max_error_px=mv.max_error_px, min_cameras=2,
                      max_combinations=mv.max_combinations).points  # fmt: skip
    ref, keep = head_pose.reference_face(), head_pose.stable_points()
    fitted = []
    for t in np.flatnonzero(several):
        ok = keep[np.isfinite(tri[t, keep]).all(axis=1)]
        r, _, _, _ = head_pose.rigid_fit(ref[ok], tri[t, ok])
        fitted.append(level @ r @ head_pose.HEAD_IN_REFERENCE)
    out["triangulated"] = turned(yaw_pitch(np.reshape(fitted, (-1, 3, 3))) - truth[several])
    return out


def rig_table(
    joints: np.ndarray,
    *,
    args: argparse.Namespace,
    model: FaceLandmarker,
    detector: BlazePoseDetector | None,
) -> Table:
    """`--rig`'s table: per rig and method, yaw and pitch error and bias, and "head °" (their
    mean, as the build's head direction error)."""
    table = Table(title=f"the head from a calibrated rig, a level frontal camera's axes: "
                        f"{args.bvh}, {len(joints)} frames over 0-20 s, 1280x720 at 3 m, the "
                        f"{args.crop}'s crop from the {args.keypoints}'s points")  # fmt: skip
    for col in ("cameras", "elevation °", "method", "frames", "yaw |err| °", "yaw bias °",
                "pitch |err| °", "pitch bias °", "head °"):  # fmt: skip
        table.add_column(col, justify="right")
    for count in args.rig:
        azimuths = rig_azimuths(centre_deg=0.0, count=count, spread_deg=args.spread)
        for el in args.elevations:
            errors = rig_errors(
                joints,
                azimuths=azimuths,
                elevation=el,
                model=model,
                crop=args.crop,
                gate=args.min_presence,
                detector=detector,
            )
            names = ",".join(f"{a:g}" for a in azimuths)
            for method, err in errors.items():
                if len(err) == 0:
                    table.add_row(f"{count} ({names}°)", f"{el:g}", method, "0", *["-"] * 5)
                    continue
                table.add_row(
                    f"{count} ({names}°)", f"{el:g}", method, str(len(err)),
                    f"{np.abs(err[:, 0]).mean():.1f}", f"{err[:, 0].mean():+.1f}",
                    f"{np.abs(err[:, 1]).mean():.1f}", f"{err[:, 1].mean():+.1f}",
                    f"{np.abs(err).mean():.1f}",
                )  # fmt: skip
    return table


def people_frames(video: Path, *, frames: int) -> tuple[list[tuple[np.ndarray, np.ndarray]], str]:
    """About `frames` frames spread over `video`, each with BlazePose's people (tracked):
    [(image, keypoints (P, K, 3))], and their skeleton."""
    rate = frames / probe(video).duration_s
    shown: list[tuple[np.ndarray, np.ndarray]] = []
    detector = BlazePoseDetector()
    detector.detect_people(
        iter_frames(video, VideoConfig(max_fps=rate)),
        on_people=lambda i, t, image, kp, ids: shown.append((image, np.array(kp))),
    )
    return shown, detector.skeleton


def pose2sim_table(*, model: FaceLandmarker, frames: int) -> Table:
    """`--pose2sim`: the faces of the Pose2Sim demos (real footage, 4 calibrated cameras each),
    `frames` frames spread over each camera's video: BlazePose's people (tracked), their face
    width (`head_pose.head_box`'s, no size limit) and the face model's presence on the build's
    crops (the body's, then the mesh's), per camera."""
    table = Table(title=f"the faces of the Pose2Sim demos: {frames} frames a camera, BlazePose's "
                        "people, the build's crops")  # fmt: skip
    for col in ("demo", "camera", "people-frames", "face seen", "face width px (median, max)",
                ">= 24 px %", "presence >= 0.5 %", "presence >= 0.1 %"):  # fmt: skip
        table.add_column(col, justify="right")
    limits = {**CROP, "min_px": 0.0}
    for demo in ("Demo_SinglePerson", "Demo_MultiPerson"):
        for video in sorted((default_samples_dir() / "pose2sim" / demo / "videos").glob("*.mp4")):
            shown, skeleton = people_frames(video, frames=frames)
            people, seen, widths, sure, found = 0, 0, [], 0, 0
            for image, kps in shown:
                for kp in kps:
                    if not np.isfinite(kp[:, 0]).any():
                        continue
                    people += 1
                    roi, _ = head_pose.head_box(keypoints=kp, skeleton=skeleton, **limits)
                    if roi is None:
                        continue
                    seen += 1
                    widths.append(roi.side / CROP_PER_WIDTH)
                    mesh = model(image, head_pose.mesh_roi(model(image, roi).points))
                    sure += mesh.presence >= 0.5
                    found += mesh.presence >= head_pose.MIN_HEAD_PRESENCE
            w = np.asarray(widths)
            table.add_row(
                demo, video.stem, str(people), str(seen),
                f"{np.median(w):.0f}, {w.max():.0f}" if len(w) else "-",
                f"{100 * np.mean(w >= 24):.0f}" if len(w) else "-",
                f"{100 * sure / max(seen, 1):.0f}", f"{100 * found / max(seen, 1):.0f}",
            )  # fmt: skip
    return table


MATCH_PX = 10.0  # `--pose2sim`: two cameras' faces are one person's below this reprojection error


def calibrated_faces(
    model: FaceLandmarker, video: Path, *, camera: Camera, frames: int
) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """Per frame of about `frames` spread over `video`: each face the model is sure of
    (presence >= 0.5) on the build's crops, as (mesh points (468, 2) px, head axes (3, 3) in the
    world of the calibrated `camera`)."""
    shown, skeleton = people_frames(video, frames=frames)
    focal, principal = np.diag(camera.K)[:2], camera.K[:2, 2]
    out = []
    for image, kps in shown:
        faces = []
        for kp in kps:
            if not np.isfinite(kp[:, 0]).any():
                continue
            roi, _ = head_pose.head_box(keypoints=kp, skeleton=skeleton, **CROP)
            if roi is None:
                continue
            mesh = model(image, head_pose.mesh_roi(model(image, roi).points))
            if mesh.presence < 0.5:
                continue
            fit = head_pose.fit_head(mesh.points3d)
            centre = camera.undistort_points(fit.centre)
            axes = head_pose.on_ray(fit.axes, centre, focal=focal, principal=principal)
            faces.append((mesh.points, camera.R.T @ axes))
        out.append(faces)
    return out


def forward_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Degrees between the forward axes (column 0) of head axes `a` and `b`."""
    return float(np.degrees(np.arccos(np.clip(a[:, 0] @ b[:, 0], -1.0, 1.0))))


def agreement_table(*, model: FaceLandmarker, frames: int) -> Table:
    """`--pose2sim`'s real-footage check: on the multi-person demo, for each pair of cameras
    that see a face in the same frame (the same person: the face pair whose triangulated mesh
    reprojects within MATCH_PX), the head from each camera alone against the head fitted to the
    triangulated mesh, beside the angle the two cameras' heads have between them (their
    spread)."""
    demo = default_samples_dir() / "pose2sim" / "Demo_MultiPerson"
    cams = load_cameras(next((demo / "calibration").glob("*.qca.txt")))
    faces = {c.name: calibrated_faces(model, demo / "videos" / f"{c.name}.mp4", camera=c,
                                      frames=frames) for c in cams}  # fmt: skip
    ref, keep = head_pose.reference_face(), head_pose.stable_points()
    title = (
        f"Pose2Sim Demo_MultiPerson, {frames} frames: the head from one camera against the "
        "triangulated face's (forward axes, °, medians)"
    )
    table = Table(title=title)
    for col in ("cameras", "frames", "reprojection px", "one camera vs triangulated °",
                "camera vs camera ° (spread)"):  # fmt: skip
        table.add_column(col, justify="right")
    for i, j in combinations(range(len(cams)), 2):
        pair = cams.subset([cams[i].name, cams[j].name])
        errors, single, spread = [], [], []
        for a_faces, b_faces in zip(faces[cams[i].name], faces[cams[j].name], strict=False):
            best = None
            for pa, wa in a_faces:
                for pb, wb in b_faces:
                    tri = triangulate(np.stack([pa, pb])[:, keep], np.ones((2, len(keep))),
                                      cameras=pair, min_confidence=0.5, max_error_px=np.inf,
                                      min_cameras=2, max_combinations=1)  # fmt: skip
                    err = float(np.nanmean(tri.error))
                    if err < MATCH_PX and (best is None or err < best[0]):
                        best = (err, tri.points, wa, wb)
            if best is None:
                continue
            err, points, wa, wb = best
            ok = np.isfinite(points).all(axis=1)
            r, _, _, _ = head_pose.rigid_fit(ref[keep][ok], points[ok])
            both = r @ head_pose.HEAD_IN_REFERENCE
            errors.append(err)
            single += [forward_angle(wa, both), forward_angle(wb, both)]
            spread.append(forward_angle(wa, wb))
        if not errors:
            continue
        table.add_row(
            f"{cams[i].name}+{cams[j].name}", str(len(errors)), f"{np.median(errors):.1f}",
            f"{np.median(single):.1f}", f"{np.median(spread):.1f}",
        )  # fmt: skip
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bvh", default="test2.bvh", help="a motion of bvhtools' testBvhFiles")
    parser.add_argument("--frames", type=int, default=40, help="frames over its first 20 s")
    parser.add_argument("--rig", type=int, nargs="+", default=[3, 4], help="cameras per rig")
    parser.add_argument("--spread", type=float, default=90.0, help="the rig's spread, degrees")
    parser.add_argument("--elevations", type=float, nargs="+", default=[0, 30])
    parser.add_argument("--crop", choices=["face", "oracle"], default="face",
                        help="the build's crops, or the render's floor (module doc)")  # fmt: skip
    parser.add_argument(
        "--keypoints",
        choices=["truth", "blazepose"],
        default="blazepose",
        help="the face points the crops are placed from (head_views.py)",
    )
    parser.add_argument(
        "--min-presence",
        type=float,
        default=head_pose.MIN_HEAD_PRESENCE,
        help="the face model's presence below which a crop gives no head (the build's default)",
    )
    parser.add_argument(
        "--pose2sim",
        action="store_true",
        help="instead: the Pose2Sim demos' faces and the real-footage check",
    )
    parser.add_argument("--quick", action="store_true", help="the oracle, 4 frames, 3 cameras")
    args = parser.parse_args()
    if args.quick:
        args.frames, args.rig, args.elevations = 4, [3], [0.0]
        args.crop, args.keypoints = "oracle", "truth"
    model = FaceLandmarker()
    if args.pose2sim:
        Console(width=140).print(pose2sim_table(model=model, frames=args.frames))
        Console(width=140).print(agreement_table(model=model, frames=args.frames))
        return
    bvh = default_samples_dir() / "bvhtools" / "testBvhFiles" / args.bvh
    _, joints = stretch(bvh, config=SynthConfig(start_s=0.0, length_s=20.0), mocap=MocapConfig())
    joints = joints[np.linspace(0, len(joints) - 1, args.frames).astype(int)]
    detector = BlazePoseDetector() if args.keypoints == "blazepose" else None
    Console(width=140).print(rig_table(joints, args=args, model=model, detector=detector))


if __name__ == "__main__":
    main()
