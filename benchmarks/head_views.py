"""The head from the face mesh alone, per view, against the render's truth (issue 40): no
detector, no lifter, no torso. Frames of a BVH are rendered from cameras around the person (level
and from above); the truth's face keypoints, projected, place the face's crop
(`extract.head_pose.head_box`, as the build does with BlazePose's); the face model runs on it and
again on its mesh's crop (`head_pose.mesh_roi`), and the rigid fit gives the head's rotation in
the camera's axes (`head_pose.on_ray`). Each view's row: frames with a crop, frames the model kept
(presence ≥ MIN_HEAD_PRESENCE), and over those the head's forward direction's yaw and pitch in the
camera's axes: mean |error| and the bias (mean signed error, positive: turned further to the
image's right / up than the truth), with the truth's mean |yaw| for scale.

`--keypoints blazepose` places the crops from BlazePose's points (each frame on its own) instead
of the truth's. The crops (`--crop`; test.bvh, 20 frames, level cameras at 0/30/60°, yaw |error|
from BlazePose's points):
- `face`: the build's (`head_box`, then `mesh_roi`): 5.1 / 5.6 / 9.4°.
- `turned`: the better (by the model's presence) of the face's crop and one 0.6 as wide centred
  half way from the nose to the ears' midpoint, then `mesh_roi`: 10.0 / 8.3 / 12.0°. In the build
  (`pipeline_truth.py`, test.bvh 0–10 s) the head went from 6.1 / 6.9 / 7.0° to 6.9 / 8.6 / 7.6°.
- `mesh`: the whole head's crop placed from the first mesh (the reference face fitted to it puts
  the nose tip and ears in the image): 11.0 / 7.3 / 13.6°. A turned face's first mesh is too
  wrong to place it (from the truth's points at 60°: 6.4 → 29°).
- `head`: the whole head's crop from the points' nose and ears (centred half way from the ears'
  midpoint to the nose, 0.15 head widths down, 1.3 head widths wide; the face's crop where the
  model finds no face there). From the truth's points it kept turns that the face's crop lost,
  but the truth's ears sit on the render's small ear ellipsoids; from BlazePose's points in the
  build it was worse (test2 at 60°: the face's frames 19° → 36° off).
So the build keeps the face's crop.

`--crop oracle` is the render's floor: no image and no model, the reference face's points where
the renderer paints them (the photo on the head's ellipsoid, `painted_face`) fitted as a perfect
3D face mesh would be. It reads every head the same: pitch 4.6–5.3° low and yaw 2.3–3.5° off
(test, test2, test3), since the reference is the model's reading of a real face and the render is
that photo flat on an ellipsoid. A triangulated face (`head_rig.py`) inherits exactly
this.

`benchmarks/head_rig.py` scores calibrated rigs (the face triangulated) and the Pose2Sim demos.

This separates the face fit from the torso the build's HeadPitch and HeadYaw are taken against
(`benchmarks/pipeline_truth.py` scores those). test2.bvh and test3.bvh are held out (report only).

    .venv/bin/python benchmarks/head_views.py [--bvh test.bvh] [--frames 40] [--crop face|turned|
        mesh|head|oracle] [--keypoints truth|blazepose] [--azimuths ...] [--elevations ...]
        [--min-presence P] [--quick]

--quick: 4 frames and one view, to check that the script runs.
"""

from __future__ import annotations

import argparse

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.config import MocapConfig, SynthConfig
from gesturebank.extract import head_pose
from gesturebank.extract.detectors.blazepose import BlazePoseDetector, Roi
from gesturebank.extract.mouth import FaceLandmarker, FaceMesh
from gesturebank.geometry import Camera
from gesturebank.samples import default_samples_dir
from gesturebank.skeletons import COCO17, get_skeleton
from gesturebank.synth.camera import orbit_camera, stage_of
from gesturebank.synth.figure import HEAD_CENTRE, HEAD_RADII, NOSE_RADII, head_frame
from gesturebank.synth.looks import LOOKS, PHOTO_EYE_DISTANCE_PX, PHOTO_EYES_MID
from gesturebank.synth.raycast import Figure, render_frames
from gesturebank.synth.take import stretch

CROP = {"min_confidence": 0.5, "max_turn": 2.75, "min_px": 24.0}  # retarget.head_* defaults
HEAD_CROP_PER_WIDTH, HEAD_CROP_DOWN = 1.3, 0.15  # `--crop head`, in head widths
NOSE_DEPTH_PER_EAR_WIDTH = 0.72  # adults: the nose tip 11.5 cm before the ears, 16 cm apart


def head_crop(keypoints: np.ndarray, *, angle: float) -> Roi:
    """`--crop head`: the whole head's crop from COCO-17 `keypoints (17, ≥2)` px (nose and both
    ears) and the eye line's `angle`. The ears' distance apart and the nose's from their midpoint
    foreshorten in turn; together they give the head's width at every turn."""
    i = COCO17.index
    nose = keypoints[i["nose"], :2]
    ears = keypoints[[i["left_ear"], i["right_ear"]], :2]
    mid = ears.mean(axis=0)
    width = float(np.hypot(np.hypot(*(ears[0] - ears[1])),
                           np.hypot(*(nose - mid)) / NOSE_DEPTH_PER_EAR_WIDTH))  # fmt: skip
    centre = (mid + nose) / 2 + HEAD_CROP_DOWN * width * np.array([-np.sin(angle), np.cos(angle)])
    return Roi(float(centre[0]), float(centre[1]), HEAD_CROP_PER_WIDTH * width, angle)


TURNED_CROP_SCALE = 0.6  # `--crop turned`: the first crop's side over the face's
# `--crop mesh`: the whole head from the first mesh. Adults: ears about 16 cm apart against a face
# about 14 cm wide at its sides (canonical mesh points 454, 234), the nose tip (1) about 11.5 cm
# before the ears.
NOSE_TIP, FACE_SIDES, EAR_PER_FACE_WIDTH = 1, (454, 234), 16.0 / 14.0


def turned_crop(face: Roi, keypoints: np.ndarray) -> Roi:
    """`--crop turned`: TURNED_CROP_SCALE × the face's crop `face` (centred on the nose),
    centred half way from the nose to the midpoint of the ears seen in COCO-17 `keypoints`."""
    ears = [keypoints[COCO17.index[n], :2] for n in ("left_ear", "right_ear")
            if keypoints[COCO17.index[n], 2] >= CROP["min_confidence"]]  # fmt: skip
    nose = np.array([face.cx, face.cy])
    centre = (nose + np.mean(ears, axis=0)) / 2 if ears else nose
    return Roi(float(centre[0]), float(centre[1]), TURNED_CROP_SCALE * face.side, face.angle)


def mesh_head_crop(points3d: np.ndarray) -> Roi:
    """`--crop mesh`: the whole head's crop (as `head_crop`) from face mesh `points3d (468, 3)`:
    the reference face fitted to its upper face places the nose tip and the ears."""
    ref, keep = head_pose.reference_face(), head_pose.stable_points()
    r, s, t, _ = head_pose.rigid_fit(ref[keep], np.asarray(points3d)[keep])
    nose, left, right = ref[NOSE_TIP], ref[FACE_SIDES[0]], ref[FACE_SIDES[1]]
    half = EAR_PER_FACE_WIDTH * (left - right) / 2
    depth = nose[2] + NOSE_DEPTH_PER_EAR_WIDTH * 2 * float(np.hypot(half[0], half[1]))
    mid = (left + right) / 2
    ears = [np.array([mid[0] + k * half[0], mid[1] + k * half[1], depth]) for k in (1, -1)]
    marks = np.array([nose, *ears]) @ (s * r).T + t
    kp = np.zeros((len(COCO17), 3))
    for name, point in zip(("nose", "left_ear", "right_ear"), marks, strict=True):
        kp[COCO17.index[name]] = (*point[:2], 1.0)
    eye = (
        np.asarray(points3d)[head_pose.EYE_CORNERS[1], :2]
        - np.asarray(points3d)[head_pose.EYE_CORNERS[0], :2]
    )
    return head_crop(kp, angle=float(np.arctan2(eye[1], eye[0])))


def coco(keypoints: np.ndarray, skeleton: str) -> np.ndarray:
    """(17, 3) COCO-17 `keypoints` of `skeleton`."""
    return get_skeleton(skeleton).convert(np.asarray(keypoints)[None], COCO17)[0]


def face_mesh(model: FaceLandmarker, image: np.ndarray, crops: list[Roi], *, gate: float):
    """The mesh from the first of `crops` where the model finds a face (the last one whatever it
    finds), after a second pass on that mesh's own crop (as the build); None where the second
    pass finds no face."""
    for k, roi in enumerate(crops):
        mesh = model(image, roi)
        if mesh.presence >= gate or k == len(crops) - 1:
            mesh = model(image, head_pose.mesh_roi(mesh.points))
            return mesh if mesh.presence >= gate else None
    return None


def painted_face(joints: np.ndarray) -> np.ndarray:
    """(T, 468, 3) world: the reference face's points where the renderer paints them on each
    frame's head (`synth.looks.face_colours`: the photo seen from the front, on the nearer of the
    head's and the nose's ellipsoids, `synth.figure`)."""
    ref = head_pose.reference_face()
    px_per_m = PHOTO_EYE_DISTANCE_PX / 0.064
    left = (ref[:, 0] - PHOTO_EYES_MID[0]) / px_per_m
    up = (PHOTO_EYES_MID[1] - ref[:, 1]) / px_per_m
    centre, axes = head_frame(joints)  # rows forward, up, left
    head_c, head_r = np.asarray(HEAD_CENTRE), np.asarray(HEAD_RADII)
    inside = 1 - ((up - head_c[1]) / head_r[1]) ** 2 - ((left - head_c[2]) / head_r[2]) ** 2
    forward = head_c[0] + head_r[0] * np.sqrt(np.clip(inside, 0, None))
    nose = np.einsum("tij,tj->ti", axes, joints[:, COCO17.index["nose"]] - centre)
    nose[:, 0] -= 0.018  # synth.figure: the nose ellipsoid's centre
    nose_r = np.asarray(NOSE_RADII)
    out = []
    for t in range(len(joints)):
        on_nose = 1 - ((up - nose[t, 1]) / nose_r[1]) ** 2 - ((left - nose[t, 2]) / nose_r[2]) ** 2
        front = nose[t, 0] + nose_r[0] * np.sqrt(np.clip(on_nose, 0, None))
        f = np.where(on_nose > 0, np.maximum(forward, front), forward)
        out.append(centre[t] + np.stack([f, up, left], axis=1) @ axes[t])
    return np.asarray(out)


def yaw_pitch(axes: np.ndarray) -> np.ndarray:
    """(..., 2) degrees: the head's forward direction (column 0 of camera-axes `axes`) turned
    towards the image's right, and up."""
    f = np.asarray(axes)[..., :, 0]
    yaw = np.arctan2(f[..., 0], -f[..., 2])
    return np.degrees(np.stack([yaw, np.arctan2(-f[..., 1], np.hypot(f[..., 0], f[..., 2]))], -1))


def turned(degrees: np.ndarray) -> np.ndarray:
    """Angle differences `degrees` brought into [-180, 180)."""
    return (np.asarray(degrees) + 180.0) % 360.0 - 180.0


def view_camera(
    joints: np.ndarray, *, azimuth: float, elevation: float, name: str = "view"
) -> Camera:
    """The camera 3 m from the person's chest, 1280×720, 50° across."""
    return orbit_camera(stage_of(joints), name=name, azimuth_deg=azimuth,
                        elevation_deg=elevation, distance_m=3.0, fov_deg=50.0,
                        size=(1280, 720))  # fmt: skip


def true_heads(joints: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """(T, 2) the truth's yaw and pitch (`yaw_pitch`) in the axes of a camera `rotation`."""
    _, axes = head_frame(joints)  # rows forward, up, left
    return yaw_pitch(np.einsum("ij,tkj->tik", rotation, axes[:, [0, 2, 1]]))


def view_heads(
    joints: np.ndarray,
    *,
    camera: Camera,
    model: FaceLandmarker,
    crop: str,
    gate: float,
    detector: BlazePoseDetector | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per frame of `joints` seen by `camera`: whether the face got a crop (T,), the head's axes
    (T, 3, 3) in the camera's axes, the mesh's points (T, 468, 2) px and the model's presence
    (T,); NaN where no head was kept."""
    n = len(joints)
    cropped = np.zeros(n, bool)
    heads = np.full((n, 3, 3), np.nan)
    points = np.full((n, head_pose.N_POINTS, 2), np.nan)
    presence = np.full(n, np.nan)
    px = camera.project(joints.reshape(-1, 3)).reshape(n, -1, 2)
    focal, principal = np.diag(camera.K)[:2], camera.K[:2, 2]
    look = LOOKS["tshirt"]
    figure = Figure(joints, np.zeros(n), look)
    painted = painted_face(joints) if crop == "oracle" else None
    images = (
        render_frames([figure], camera, scenery=look, supersample=1)
        if painted is None
        else [None] * n  # the truth mesh: no render, no model
    )
    skeleton = COCO17.name
    if detector is not None and painted is None:
        images = list(images)
        found = detector.detect_each_frame((k * 0.5, im) for k, im in enumerate(images))
        skeleton = found.skeleton
    for k, image in enumerate(images):
        if skeleton == COCO17.name:
            kp = np.concatenate([px[k], np.ones((len(COCO17), 1))], axis=1)
        else:
            kp = found.keypoints[k]
        roi, _ = head_pose.head_box(keypoints=kp, skeleton=skeleton, **CROP)
        if roi is None:
            continue
        cropped[k] = True
        if painted is not None:
            # the painted points in the camera's own axes (scaled to px at the face's distance):
            # their fit is the head in the camera's axes, no turn onto the face's ray
            cam = camera.to_camera(painted[k])
            scaled = cam * focal.mean() / cam[:, 2].mean()
            mesh = FaceMesh(camera.project(painted[k]), 1.0, np.nan, scaled)
        elif crop in ("turned", "mesh"):
            first = model(image, roi)
            if crop == "turned":
                turned = model(image, turned_crop(roi, coco(kp, skeleton)))
                first = turned if turned.presence >= first.presence else first
                mesh = model(image, head_pose.mesh_roi(first.points))
            else:
                mesh = model(image, mesh_head_crop(first.points3d))
            mesh = mesh if mesh.presence >= gate else None
        else:
            crops = (
                [roi] if crop == "face" else [head_crop(coco(kp, skeleton), angle=roi.angle), roi]
            )
            mesh = face_mesh(model, image, crops, gate=gate)
        if mesh is None:
            continue
        fit = head_pose.fit_head(mesh.points3d)
        heads[k] = (
            fit.axes
            if painted is not None
            else head_pose.on_ray(fit.axes, fit.centre, focal=focal, principal=principal)
        )
        points[k] = mesh.points
        presence[k] = mesh.presence
    return cropped, heads, points, presence


def view_errors(
    joints: np.ndarray,
    *,
    azimuth: float,
    elevation: float,
    model: FaceLandmarker,
    crop: str,
    gate: float,
    detector: BlazePoseDetector | None = None,
) -> tuple[int, np.ndarray, np.ndarray]:
    """(frames with a crop, errors (K, 2) yaw/pitch of the K kept frames, truth (K, 2))."""
    camera = view_camera(joints, azimuth=azimuth, elevation=elevation)
    cropped, heads, _, _ = view_heads(
        joints, camera=camera, model=model, crop=crop, gate=gate, detector=detector
    )
    kept = np.isfinite(heads).all(axis=(1, 2))
    truth = true_heads(joints, camera.R)[kept]
    return int(cropped.sum()), turned(yaw_pitch(heads[kept]) - truth), truth


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bvh", default="test.bvh", help="a motion of bvhtools' testBvhFiles")
    parser.add_argument("--frames", type=int, default=40, help="frames over its first 20 s")
    parser.add_argument(
        "--crop",
        choices=["face", "turned", "mesh", "head", "oracle"],
        default="face",
        help="the face's crop (the build's) or the whole head's (module doc)",
    )
    parser.add_argument(
        "--min-presence",
        type=float,
        default=head_pose.MIN_HEAD_PRESENCE,
        help="the face model's presence below which a crop gives no head (the build's default)",
    )
    parser.add_argument(
        "--keypoints",
        choices=["truth", "blazepose"],
        default="truth",
        help="the face points the crops are placed from: the truth's or BlazePose's, each frame "
        "on its own (the build's, without its tracking)",
    )
    parser.add_argument("--azimuths", type=float, nargs="+", default=[0, 30, 45, 60, 75, 90])
    parser.add_argument("--elevations", type=float, nargs="+", default=[0, 30])
    parser.add_argument("--quick", action="store_true", help="4 frames, one view")
    args = parser.parse_args()
    n = 4 if args.quick else args.frames
    views = [(60, 0)] if args.quick else [
        (az, el) for el in args.elevations for az in args.azimuths
    ]  # fmt: skip
    bvh = default_samples_dir() / "bvhtools" / "testBvhFiles" / args.bvh
    _, joints = stretch(bvh, config=SynthConfig(start_s=0.0, length_s=20.0), mocap=MocapConfig())
    joints = joints[np.linspace(0, len(joints) - 1, n).astype(int)]
    model = FaceLandmarker()
    detector = BlazePoseDetector() if args.keypoints == "blazepose" else None
    table = Table(title=f"the head from the face mesh per view, camera axes: {args.bvh}, {n} "
                        f"frames over 0-20 s, 1280x720 at 3 m, the {args.crop}'s crop, presence "
                        f">= {args.min_presence:g}")  # fmt: skip
    for col in ("azimuth °", "elevation °", "cropped", "kept", "truth |yaw| °", "yaw |err| °",
                "yaw bias °", "pitch |err| °", "pitch bias °"):  # fmt: skip
        table.add_column(col, justify="right")
    for az, el in views:
        cropped, err, truth = view_errors(
            joints,
            azimuth=az,
            elevation=el,
            model=model,
            crop=args.crop,
            gate=args.min_presence,
            detector=detector,
        )
        if len(err) == 0:
            table.add_row(f"{az:g}", f"{el:g}", str(cropped), "0", *["-"] * 5)
            continue
        table.add_row(
            f"{az:g}", f"{el:g}", str(cropped), str(len(err)),
            f"{np.abs(truth[:, 0]).mean():.1f}",
            f"{np.abs(err[:, 0]).mean():.1f}", f"{err[:, 0].mean():+.1f}",
            f"{np.abs(err[:, 1]).mean():.1f}", f"{err[:, 1].mean():+.1f}",
        )  # fmt: skip
    Console(width=140).print(table)


if __name__ == "__main__":
    main()
