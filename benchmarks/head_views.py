"""The head from the face mesh alone, per view, against the render's truth (issue 40): no
detector, no lifter, no torso. Frames of a BVH are rendered from cameras around the person (level
and from above); the truth's face keypoints, projected, place the head's crops
(`extract.head_pose.head_box`, as the build does with BlazePose's); the face model
(`head_pose.head_mesh`) and the rigid fit give the head's rotation in the camera's axes
(`head_pose.on_ray`). Each view's row: frames
with a crop, frames the model kept (presence ≥ MIN_HEAD_PRESENCE), and over those the head's
forward direction's yaw and pitch in the camera's axes: mean |error| and the bias (mean signed
error, positive: turned further to the image's right / up than the truth), with the truth's
mean |yaw| for scale.

This separates the face fit from the torso the build's HeadPitch and HeadYaw are taken against
(`benchmarks/pipeline_truth.py` scores those). The crop and the presence gate were chosen on
test.bvh; test2.bvh and test3.bvh are held out (report only).

    .venv/bin/python benchmarks/head_views.py [--bvh test.bvh] [--frames 40] [--quick]

--quick: 4 frames and one view, to check that the script runs.
"""

from __future__ import annotations

import argparse

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.config import MocapConfig, SynthConfig
from gesturebank.extract import head_pose
from gesturebank.extract.mouth import FaceLandmarker
from gesturebank.samples import default_samples_dir
from gesturebank.skeletons import COCO17
from gesturebank.synth.camera import orbit_camera, stage_of
from gesturebank.synth.figure import head_frame
from gesturebank.synth.looks import LOOKS
from gesturebank.synth.raycast import Figure, render_frames
from gesturebank.synth.take import stretch

CROP = {"min_confidence": 0.5, "max_turn": 2.75, "min_px": 24.0}  # retarget.head_* defaults


def yaw_pitch(axes: np.ndarray) -> np.ndarray:
    """(..., 2) degrees: the head's forward direction (column 0 of camera-axes `axes`) turned
    towards the image's right, and up."""
    f = np.asarray(axes)[..., :, 0]
    yaw = np.arctan2(f[..., 0], -f[..., 2])
    return np.degrees(np.stack([yaw, np.arctan2(-f[..., 1], np.hypot(f[..., 0], f[..., 2]))], -1))


def view_errors(
    joints: np.ndarray, *, azimuth: float, elevation: float, model: FaceLandmarker
) -> tuple[int, np.ndarray, np.ndarray]:
    """(frames with a crop, errors (K, 2) yaw/pitch of the K kept frames, truth (K, 2))."""
    camera = orbit_camera(stage_of(joints), name="view", azimuth_deg=azimuth,
                          elevation_deg=elevation, distance_m=3.0, fov_deg=50.0,
                          size=(1280, 720))  # fmt: skip
    _, axes = head_frame(joints)  # rows forward, up, left
    truth = yaw_pitch(np.einsum("ij,tkj->tik", camera.R, axes[:, [0, 2, 1]]))
    px = camera.project(joints.reshape(-1, 3)).reshape(len(joints), -1, 2)
    focal, principal = np.diag(camera.K)[:2], camera.K[:2, 2]
    look = LOOKS["tshirt"]
    figure = Figure(joints, np.zeros(len(joints)), look)
    cropped, errors, kept = 0, [], []
    for k, image in enumerate(render_frames([figure], camera, scenery=look, supersample=1)):
        kp = np.concatenate([px[k], np.ones((len(COCO17), 1))], axis=1)
        crops, _ = head_pose.head_box(keypoints=kp, skeleton=COCO17.name, **CROP)
        if crops is None:
            continue
        cropped += 1
        mesh = head_pose.head_mesh(model=model, image=image, crops=crops)
        if mesh is None:
            continue
        fit = head_pose.fit_head(mesh.points3d)
        got = head_pose.on_ray(fit.axes, fit.centre, focal=focal, principal=principal)
        errors.append(yaw_pitch(got) - truth[k])
        kept.append(truth[k])
    return cropped, np.reshape(errors, (-1, 2)), np.reshape(kept, (-1, 2))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bvh", default="test.bvh", help="a motion of bvhtools' testBvhFiles")
    parser.add_argument("--frames", type=int, default=40, help="frames over its first 20 s")
    parser.add_argument("--quick", action="store_true", help="4 frames, one view")
    args = parser.parse_args()
    n = 4 if args.quick else args.frames
    views = [(60, 0)] if args.quick else [
        (az, el) for el in (0, 30) for az in (0, 30, 45, 60, 75, 90)
    ]  # fmt: skip
    bvh = default_samples_dir() / "bvhtools" / "testBvhFiles" / args.bvh
    _, joints = stretch(bvh, config=SynthConfig(start_s=0.0, length_s=20.0), mocap=MocapConfig())
    joints = joints[np.linspace(0, len(joints) - 1, n).astype(int)]
    model = FaceLandmarker()
    table = Table(title=f"the head from the face mesh per view, camera axes: {args.bvh}, {n} "
                        "frames over 0-20 s, 1280x720 at 3 m")  # fmt: skip
    for col in ("azimuth °", "elevation °", "cropped", "kept", "truth |yaw| °", "yaw |err| °",
                "yaw bias °", "pitch |err| °", "pitch bias °"):  # fmt: skip
        table.add_column(col, justify="right")
    for az, el in views:
        cropped, err, truth = view_errors(joints, azimuth=az, elevation=el, model=model)
        if len(err) == 0:
            table.add_row(str(az), str(el), str(cropped), "0", *["-"] * 5)
            continue
        table.add_row(
            str(az), str(el), str(cropped), str(len(err)),
            f"{np.abs(truth[:, 0]).mean():.1f}",
            f"{np.abs(err[:, 0]).mean():.1f}", f"{err[:, 0].mean():+.1f}",
            f"{np.abs(err[:, 1]).mean():.1f}", f"{err[:, 1].mean():+.1f}",
        )  # fmt: skip
    Console(width=140).print(table)


if __name__ == "__main__":
    main()
