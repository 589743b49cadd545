"""The whole build on held-out renders, reported as a measuring instrument's error (issue 39).

Renders of test2.bvh (never trained or tuned on): its calm first 20 s and its most vigorous 20 s,
a level camera in front and one 0.5 m above the chest looking down, both looks (T-shirt, long
sleeves), and the calm motion from level cameras 30° and 60° round (T-shirt), 1280×720. Each
goes through `build-dataset` with its defaults (clips split into parts of at most 5 s, the
bootstrap's units), and every stored clip, accepted or not, is scored against the truth
through the build's processing. Per render: the accepted seconds, arm MAE, Pepper hand error,
wrong depth signs, head direction, and the stored 2D against BlazePose run on each frame alone
(worst-joint 90th percentile, % of the torso; frames with left and right exchanged). Pooled, per
Pepper joint: bias, 95 % limits of agreement, ICC(2,1) and MAE, each with a 95 % bootstrap
interval over clips (`lift.agreement`).

    .venv/bin/python benchmarks/heldout.py [--quick] [--onnx FILE]

--onnx: the `learned` lifter's net (default: the packaged one), to compare nets in one run.

--quick: the fast stretch's first 3.5 s, level and elevated, one look, 640×360 (seconds with the
renders and detections cached).

--floors (instead of the build; not part of --quick): how much of the lifter's error each thing
it cannot see costs (issue 39's floors). The default lifter alone on the T-shirt renders, from
the true 2D and from BlazePose as the build runs it (tracked), as lifted and with things set
true by an oracle (`lift.scoring`): each arm bone's depth sign along the camera ray (the frontal
ambiguity), the torso's tilt towards the camera (the hips turned about the neck; turning the
whole body would change no angle) and both; and each joint put on its 2D ray at the true depth
(no lifter: the error of the 2D alone, the detector's share; none for the true 2D). The lift as
lifted and the 2D at true depth also through the build's processing of the angles (low-pass,
reach, speed limit), as the whole build would store them (no QC, no clips). Then the same on
Pose2Sim's Demo_SinglePerson (real footage), each camera against the 4-camera triangulation.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
from fidelity import IMAGE, TRUTH_BVH, detect_cached, mean_median, render_truth
from rich.console import Console
from rich.table import Table

from gesturebank.app.build import build_dataset
from gesturebank.app.extract import extract_take
from gesturebank.camera_files import CameraGroup, load_cameras
from gesturebank.config import Config, SynthConfig
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.process import process_angles
from gesturebank.datasets.takes import discover_takes, find_calibration
from gesturebank.lift import LIFTERS, TakeViews
from gesturebank.lift.agreement import Interval, agreement, bootstrap_over_clips
from gesturebank.lift.multiview.lifter import MultiviewLifter, match_videos
from gesturebank.lift.scoring import (
    ARM_JOINTS,
    angle_error_deg,
    at_true_depth,
    averaged_directions,
    camera_axes,
    project_view,
    score_angles,
    sign_errors,
    with_nearer_directions,
    with_true_depth_signs,
    with_true_tilt,
)
from gesturebank.mocap.bvh import read_bvh
from gesturebank.mocap.pose import motion_pose
from gesturebank.robot import pepper
from gesturebank.robot.pepper import JOINTS
from gesturebank.robot.retarget import pepper_angles
from gesturebank.samples import default_samples_dir
from gesturebank.skeletons import COCO17
from gesturebank.synth.score import score_2d, worst_joint_p90
from gesturebank.synth.truth import Truth

# The held-out agreement (issue 39): test2.bvh's calm first 20 s and its most vigorous 20 s,
# a level camera and one ELEVATED_M above the chest looking down, both looks, the whole build.
HELDOUT, HELDOUT_S = "test2", 20.0
ELEVATED_M = 0.5
ELEVATION_DEG = float(np.rad2deg(np.arcsin(ELEVATED_M / 3.0)))  # the renders' camera is 3 m away
# camera name → (azimuth from the front, elevation, degrees), and the motions and looks it films
CAMERAS = {"level": (0.0, 0.0), "elevated": (0.0, ELEVATION_DEG), "level 30°": (30.0, 0.0),
           "level 60°": (60.0, 0.0)}  # fmt: skip
LOOKS = ("tshirt", "sleeves")
TURNED = {"level 30°", "level 60°"}  # the acceptance's calm views; one look, to keep the run short
QUICK_HELDOUT_S, QUICK_HELDOUT = 3.5, (640, 360)  # a clip lasts at least 3 s (clips.min_s)
CLIP_S = 5.0  # held-out builds split clips into parts this long at most: the bootstrap units
DRAWS, QUICK_DRAWS = 1000, 100  # bootstrap draws over clips


def most_vigorous_start(config: Config, motion: str, length_s: float) -> float:
    """Start (s, on a 0.5 s grid) of the `length_s` stretch of `motion`.bvh whose wrists move
    fastest relative to the mid-shoulder (path length): the fast, expressive held-out motion."""
    pose = motion_pose(read_bvh(default_samples_dir() / TRUTH_BVH.format(motion)),
                       config=config.mocap)[0]  # fmt: skip
    joints, times = pose.joints.astype(np.float64), pose.timestamps
    wrists = joints[:, [COCO17.index["left_wrist"], COCO17.index["right_wrist"]]]
    relative = wrists - joints[:, [5, 6]].mean(axis=1, keepdims=True)
    path = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(relative, axis=0), axis=-1)
                                            .sum(axis=1))])  # fmt: skip
    starts = np.arange(0.0, times[-1] - length_s, 0.5)
    ends = np.searchsorted(times, starts + length_s)
    return float(starts[np.argmax(path[ends] - path[np.searchsorted(times, starts)])])


def build_and_pair(truth: Truth, config: Config, out: Path) -> list[dict[str, np.ndarray]]:
    """`build-dataset` on the render's video; per stored clip (accepted or not): the stored
    angles and the truth through the build's processing (`angles`, `truth`, (N, 11) rad on the
    clip's clock), its stored 2D and the true 2D of its video frames (`2d`, `true 2d`), and
    `accepted` (0-d bool), and its arm bones' depth signs (`signs`: (bones, 2) deep frames,
    wrong ones; `lift.scoring.sign_errors`)."""
    build_dataset(
        discover_takes(truth.videos[0].parent),
        videos_dir=truth.videos[0].parent,
        out=out,
        config=config,
    )
    dataset = open_dataset(out)
    profile = pepper.load_profile(config.robot.profile)
    clips = []
    for row in (r for r in dataset.rows() if r.clip.kind == "clip"):
        clip = dataset.load(row.clip.clip_id)
        true = process_angles(raw=truth.angles, timestamps=truth.times,
                              clock=clip.times + clip.start_s, processing=config.processing,
                              retarget=config.retarget, profile=profile)  # fmt: skip
        frames = np.round((clip.pose2d.timestamps + clip.start_s - truth.times[0]) * truth.fps)
        frames = np.clip(frames.astype(int), 0, len(truth.times) - 1)
        clips.append({
            "angles": clip.angles.astype(np.float64), "truth": true.angles.astype(np.float64),
            "2d": clip.pose2d.to_coco17().keypoints, "true 2d": truth.joints2d[0][frames],
            "accepted": np.array(row.clip.qc_status == "accepted"),
            "signs": np.array([v for v in sign_errors(camera_axes(clip.pose3d),
                                                      truth.joints3d[frames],
                                                      camera=truth.cameras[0]).values()]),
        })  # fmt: skip
    return clips


def heldout_tables(config: Config, *, quick: bool) -> tuple[Table, Table]:
    """The whole build on held-out renders as a measuring instrument (issue 39): per render,
    its scores and its stored 2D against BlazePose run on each frame alone; per Pepper joint,
    bias, 95 % limits of agreement, ICC(2,1) and MAE with bootstrap intervals over clips."""
    length = QUICK_HELDOUT_S if quick else HELDOUT_S
    size = QUICK_HELDOUT if quick else IMAGE
    fast = most_vigorous_start(config, HELDOUT, HELDOUT_S)
    motions = {"fast": fast} if quick else {"calm": 0.0, "fast": fast}
    looks = LOOKS[:1] if quick else LOOKS
    renders = Table(title=f"Held-out renders of {HELDOUT}.bvh (calm: 0–{HELDOUT_S:g} s, fast: its "
                    f"most vigorous {HELDOUT_S:g} s from {fast:g} s; {length:g} s each, "
                    f"{size[0]}×{size[1]}) through the whole build, every stored clip scored "
                    "(accepted or not); 2D: the stored 2D against BlazePose on each frame alone "
                    "(worst-joint p90, % torso; frames with left and right exchanged)")  # fmt: skip
    config = config.model_copy(update={"clips": config.clips.model_copy(update={"max_s": CLIP_S})})
    for col in ("motion", "camera", "look", "clips", "accepted s", "arm MAE °", "hand cm",
                "wrong sign %", "head °", "2D p90 %: stored / each frame",
                "L/R exchanged %: stored / each frame"):  # fmt: skip
        renders.add_column(col, justify="right")
    pooled: list[dict[str, np.ndarray]] = []
    with tempfile.TemporaryDirectory(prefix="fidelity-heldout-") as tmp:
        for kind, start in motions.items():
            for camera, (azimuth, elevation) in CAMERAS.items():
                if camera in TURNED and kind != "calm":
                    continue
                for look in looks[:1] if camera in TURNED else looks:
                    synth = SynthConfig(azimuths_deg=[azimuth], start_s=start, length_s=length,
                                        elevation_deg=elevation, look=look,
                                        width_px=size[0], height_px=size[1])  # fmt: skip
                    truth = render_truth(config, synth, HELDOUT)
                    clips = build_and_pair(truth, config, Path(tmp) / f"{kind}-{camera}-{look}")
                    pooled += clips
                    renders.add_row(kind, camera, look, *render_cells(clips, truth, config))
    return renders, agreement_table(pooled, draws=QUICK_DRAWS if quick else DRAWS)


def render_cells(clips: list[dict[str, np.ndarray]], truth: Truth, config: Config) -> list[str]:
    """One render's row of `heldout_tables` after its motion, camera and look."""
    if not clips:
        return ["0", *["-"] * 7]
    rate = config.processing.rate_hz
    accepted = sum(len(c["angles"]) for c in clips if c["accepted"]) / rate
    angles, true = (np.concatenate([c[k] for c in clips]) for k in ("angles", "truth"))
    per_joint, _, hand, head = score_angles(angles, true)
    stored = np.concatenate([c["2d"] for c in clips])
    true_2d = np.concatenate([c["true 2d"] for c in clips])
    each = detect_cached(config, truth.videos[0], each_frame=True).to_coco17().keypoints
    signs = np.sum([c["signs"].sum(axis=0) for c in clips], axis=0)
    return [
        str(len(clips)), f"{accepted:.1f} / {len(truth.times) / truth.fps:g}",
        f"{np.nanmean(per_joint[ARM_JOINTS]):.1f}", f"{hand:.1f}",
        f"{100 * signs[1] / max(signs[0], 1):.0f}", f"{head:.1f}",
        f"{worst_joint_p90(stored, true_2d):.0f} / {worst_joint_p90(each, truth.joints2d[0]):.0f}",
        f"{100 * score_2d(stored, true_2d).swapped:.1f} / "
        f"{100 * score_2d(each, truth.joints2d[0]).swapped:.1f}",
    ]  # fmt: skip


def agreement_table(clips: list[dict[str, np.ndarray]], *, draws: int) -> Table:
    """Per Pepper joint, the stored angles against the truth over `clips` (°): bias, 95 % limits
    of agreement, ICC(2,1), MAE, each 'value [95 % bootstrap interval over clips]'; and the head
    direction's error (°)."""
    table = Table(title=f"Agreement of the stored angles with the truth, {len(clips)} clips "
                  "pooled (°; [95 % bootstrap interval, clips resampled]; one clip: "
                  "none)")  # fmt: skip
    for col in ("joint", "bias °", "lower limit °", "upper limit °", "ICC(2,1)", "MAE °",
                "readings"):  # fmt: skip
        table.add_column(col, justify="right")

    def cell(i: Interval, digits: int = 1) -> str:
        return i.text(digits) if np.isfinite(i.low) else f"{i.value:.{digits}f}"

    for j, name in enumerate(JOINTS):
        pairs = [(np.rad2deg(c["angles"][:, j]), np.rad2deg(c["truth"][:, j])) for c in clips]
        got = agreement(pairs, draws=draws)
        table.add_row(name, cell(got.bias), cell(got.lower), cell(got.upper), cell(got.icc, 2),
                      cell(got.mae), str(got.readings))  # fmt: skip
    head = bootstrap_over_clips([(c["angles"], c["truth"]) for c in clips],
                                lambda a, t: score_angles(a, t)[3], draws=draws)  # fmt: skip
    table.add_row("head direction", "", "", "", "", cell(head), "")
    return table


TWO_LIFTS = {  # issue 39: BlazePose's world landmarks as a second input, combined with the net's
    "blazepose-world": lambda j, w, t: w,
    "directions averaged 0.75": lambda j, w, t: averaged_directions(j, w, weight=0.75),
    "directions averaged 0.5": lambda j, w, t: averaged_directions(j, w, weight=0.5),
    "the nearer of the two (oracle)": lambda j, w, t: with_nearer_directions(j, w, truth_camera=t),
}


def floors_table(config: Config) -> tuple[Table, Table]:
    """The default lifter alone on the held-out T-shirt renders, from the true 2D and from
    BlazePose, as lifted and with oracles, and the 2D at the true depths (module doc): arm MAE
    ° / hand cm, and the wrong depth signs as lifted; the first and last also through the
    build's processing (low-pass, reach, speed limit: `process_angles`, truth likewise). And
    from BlazePose, its world landmarks (`blazepose-world`) and their combinations with the
    lift (`TWO_LIFTS`), processed."""
    oracles = {
        "as lifted": lambda j, t: j,
        "true depth signs": with_true_depth_signs,
        "true torso tilt": with_true_tilt,
        "both": lambda j, t: with_true_tilt(with_true_depth_signs(j, t), t),
    }
    fast = most_vigorous_start(config, HELDOUT, HELDOUT_S)
    table = Table(title=f"Floors: the `{config.lifter.name}` lifter alone on the held-out "
                  f"T-shirt renders of {HELDOUT}.bvh (calm 0–{HELDOUT_S:g} s, fast from "
                  f"{fast:g} s), arm MAE ° / Pepper hand cm, as lifted and with things set "
                  "true")  # fmt: skip
    for col in ("motion", "camera", "2D", "wrong sign %", *oracles, "the 2D at true depth",
                "processed: as lifted", "processed: 2D at true depth"):  # fmt: skip
        table.add_column(col, justify="right")
    two = Table(title="Two lifts of BlazePose's 2D, the lift and BlazePose's world landmarks, "
                "combined bone by bone (`lift.scoring`), processed as the build does: arm MAE ° "
                "/ Pepper hand cm")  # fmt: skip
    for col in ("motion", "camera", f"{config.lifter.name}", *TWO_LIFTS):
        two.add_column(col, justify="right")
    lifter = LIFTERS.create(config.lifter.name, config)
    world_lifter = LIFTERS.create("blazepose-world", config)
    profile = pepper.load_profile(config.robot.profile)

    def processed(angles: np.ndarray, times: np.ndarray) -> np.ndarray:
        clock = np.arange(times[0], times[-1], 1.0 / config.processing.rate_hz)
        return process_angles(raw=angles, timestamps=times, clock=clock,
                              processing=config.processing, retarget=config.retarget,
                              profile=profile).angles.astype(np.float64)  # fmt: skip

    def cell(angles: np.ndarray, true: np.ndarray) -> str:
        per_joint, _, hand, _ = score_angles(angles, true)
        return f"{np.nanmean(per_joint[ARM_JOINTS]):.1f} / {hand:.1f}"

    for kind, start in {"calm": 0.0, "fast": fast}.items():
        for camera, (azimuth, elevation) in CAMERAS.items():
            if camera in TURNED and kind != "calm":
                continue
            synth = SynthConfig(azimuths_deg=[azimuth], start_s=start, length_s=HELDOUT_S,
                                elevation_deg=elevation, look=LOOKS[0], width_px=IMAGE[0],
                                height_px=IMAGE[1])  # fmt: skip
            truth = render_truth(config, synth, HELDOUT)
            cam, world = truth.cameras[0], truth.joints3d.astype(np.float64)
            seen = cam.to_camera(world)
            true_angles = pepper_angles(world, config=config.retarget)
            sources = {
                "true": project_view(world, cam, timestamps=truth.times),
                "BlazePose": detect_cached(config, truth.videos[0]),
            }
            for source, pose in sources.items():
                lifted = camera_axes(lifter.lift(TakeViews.of(pose, CameraGroup([cam]))))
                signs = np.sum(list(sign_errors(lifted, world, camera=cam).values()), axis=0)
                angles = {name: pepper_angles(oracle(lifted, seen), config=config.retarget)
                          for name, oracle in oracles.items()}  # fmt: skip
                placed = at_true_depth(pose.to_coco17().keypoints, camera=cam, truth_camera=seen)
                angles["placed"] = pepper_angles(placed, config=config.retarget)
                cells = [cell(a, true_angles) for a in angles.values()]
                true_processed = processed(true_angles, truth.times)
                for name in ("as lifted", "placed"):
                    cells.append(cell(processed(angles[name], truth.times), true_processed))
                table.add_row(kind, camera, source, f"{100 * signs[1] / max(signs[0], 1):.0f}",
                              *cells)  # fmt: skip
                if source == "BlazePose":
                    world = camera_axes(world_lifter.lift(TakeViews.of(pose, CameraGroup([cam]))))
                    combined = [pepper_angles(combine(lifted, world, seen), config=config.retarget)
                                for combine in TWO_LIFTS.values()]  # fmt: skip
                    scores = [cell(processed(a, truth.times), true_processed) for a in combined]
                    two.add_row(kind, camera, cells[-2], *scores)
    return table, two


def pose2sim_floors_table(given: Config) -> Table:
    """Pose2Sim Demo_SinglePerson (real footage, 60 fps): each camera lifted alone by `given`'s
    lifter against the 4-camera triangulation (fidelity.py's (c): mean Pepper angle error over
    the 11 joints), as lifted and with the oracles of `floors_table` taking the triangulation
    for the truth, and combined with `blazepose-world` (`TWO_LIFTS`; issue 39's Pose2Sim line)."""
    root = default_samples_dir() / "pose2sim" / "Demo_SinglePerson"
    config = Config.model_validate({"video": {"max_fps": None}})  # the demo's 60 fps
    config = config.model_copy(update={"lifter": given.lifter})
    cams = load_cameras(find_calibration(root))
    videos = match_videos(cams, sorted((root / "videos").glob("*.mp4")))
    poses = [extract_take(v, config, with_audio=False).tracked.pose for v in videos]
    reference = MultiviewLifter.from_config(config).lift(TakeViews.of(poses, cams))
    world = reference.joints.astype(np.float64)
    ref_angles = pepper_angles(reference, config=config.retarget)
    variants = {
        "blazepose-world": None,
        f"{config.lifter.name}, as lifted": lambda j, t: j,
        "true depth signs": with_true_depth_signs,
        "true torso tilt": with_true_tilt,
        "both": lambda j, t: with_true_tilt(with_true_depth_signs(j, t), t),
    }
    table = Table(title="Floors on Pose2Sim Demo_SinglePerson: mean Pepper angle error (°) of "
                  "each camera alone against the 4-camera triangulation, oracles taking the "
                  "triangulation for the truth")  # fmt: skip
    for col in ("lift", *cams.names):
        table.add_column(col, justify="right")
    lifters = {
        name: LIFTERS.create(name, config) for name in ("blazepose-world", config.lifter.name)
    }
    combined = [name for name in TWO_LIFTS if name != "blazepose-world"]
    rows: dict[str, list[str]] = {name: [] for name in (*variants, *combined,
                                                        "the 2D at true depth")}  # fmt: skip
    for c, cam in enumerate(cams):
        view = TakeViews.of(poses[c], cams.subset([cams.names[c]]))
        seen = cam.to_camera(world)
        lifted = camera_axes(lifters[config.lifter.name].lift(view))
        angles = {name: pepper_angles(camera_axes(lifters[name].lift(view)) if oracle is None
                                      else oracle(lifted, seen), config=config.retarget)
                  for name, oracle in variants.items()}  # fmt: skip
        other = camera_axes(lifters["blazepose-world"].lift(view))
        for name in combined:
            angles[name] = pepper_angles(TWO_LIFTS[name](lifted, other, seen),
                                         config=config.retarget)  # fmt: skip
        placed = at_true_depth(poses[c].to_coco17().keypoints, camera=cam, truth_camera=seen)
        angles["the 2D at true depth"] = pepper_angles(placed, config=config.retarget)
        for name, a in angles.items():
            rows[name].append(f"{np.nanmean(mean_median(angle_error_deg(a, ref_angles))[0]):.1f}")
    for name, cells in rows.items():
        table.add_row(name, *cells)
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one short render pair (seconds)")
    parser.add_argument("--onnx", type=Path, help="the learned lifter's net (default: packaged)")
    parser.add_argument("--floors", action="store_true",
                        help="the lifter alone with oracles, instead of the build")  # fmt: skip
    args = parser.parse_args()
    config = Config()
    if args.onnx is not None:
        learned = config.lifter.learned.model_copy(update={"onnx_file": str(args.onnx.resolve())})
        lifter = config.lifter.model_copy(update={"learned": learned})
        config = config.model_copy(update={"lifter": lifter})
    console = Console(width=max(Console().width, 160))  # 11 columns: keep them readable
    if args.floors:
        for table in floors_table(config):
            console.print(table)
        console.print(pose2sim_floors_table(config))
        return
    for table in heldout_tables(config, quick=args.quick):
        console.print(table)


if __name__ == "__main__":
    main()
