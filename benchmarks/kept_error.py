"""Are the seconds QC keeps no worse than the whole take (issue 41)? Kept seconds' error against
the truth, beside every second's and the cut seconds', on renders and motion-capture windows.

Each take is built once with clips judged whole (`qc.stretch_rounds` 0, so every clip is stored,
accepted or not: "all" is the whole take as the build made it), then a copy is re-judged with the
config under test (`gesturebank qc`'s refresh, which cuts as the build does). Each 100 Hz sample
of the whole build is scored against the truth through the build's own processing
(`process_angles`: "limited", what a perfect lift would store) and against the person's angles
not brought into Pepper's reach ("person"); the samples are split by whether the re-judged
dataset kept their time. Per take: kept %, arm-angle MAE (the eight arm joints, °) and Pepper
hand error (cm) of all, kept and cut seconds, and the seconds cut by reason.

- renders: `test.bvh` 31–51 s (QC is tuned on these), held-out `test2.bvh` 0–20 s and
  `test3.bvh` 20–40 s (reported only), level at 0°, 30°, 60° and from above at 0° (elevation
  9.6°), as `benchmarks/yield.py --renders` makes them (cached by checksum);
- motion capture (`--mocap`): every 30 s window of test.bvh as a take of its own, the truth the
  BVH itself (its kept/cut split is about reach, not lifting).

    .venv/bin/python benchmarks/kept_error.py [--quick] [--mocap] [--motions test test2 test3]
        [--azimuths 75 90]
        [--set qc.KEY=VALUE ...] [--out DIR]

--quick: test.bvh 31–51 s at 60° only. `--set` re-judges with QC settings changed (the build is
reused: only the re-judging runs again). `--by-yaw` (renders): per take, the samples binned by
how far the person's torso is truly turned from the camera (the truth's shoulders and hips in
the camera's frame, about the torso's up axis: 0° facing it, 90° side on), with the share the
2D calls seen from the side (`qc.views.sideways`) and the arm and hand error per bin, and where
the cut samples lie: what the sideways rule is in terms of the truth.
"""

from __future__ import annotations

import argparse
import itertools
import json
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.app.build import build_dataset
from gesturebank.config import Config, SynthConfig
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.process import process_angles
from gesturebank.datasets.refresh import refresh
from gesturebank.datasets.takes import discover_takes
from gesturebank.footage import SPEECH
from gesturebank.lift.scoring import ARM_JOINTS, score_angles
from gesturebank.robot import pepper
from gesturebank.robot.pepper import JOINTS, fk
from gesturebank.samples import default_samples_dir
from gesturebank.synth.take import Performer, cached_render, render_cache

RENDERS = {"test": 31.0, "test2": 0.0, "test3": 20.0}  # motion → start s; 20 s each
VIEWS = ((0.0, 0.0), (30.0, 0.0), (60.0, 0.0), (0.0, 9.6))  # (azimuth, elevation) °
LENGTH_S = 20.0
WINDOW_S = 30.0


@dataclass
class Samples:
    """A whole build's 100 Hz samples: time in the take (s), stored angles, the two truths."""

    times: np.ndarray
    stored: np.ndarray
    limited: np.ndarray
    person: np.ndarray


def render_folder(motion: str, azimuth: float, elevation: float, videos: Path):
    """The cached render (as yield.py makes it) linked into a subject folder of `videos`;
    returns (folder, truth times, truth angles). A folder linked before keeps its render (the
    render cache's key holds the renderer's code: a change elsewhere would render again)."""
    from gesturebank.synth.truth import Truth

    up = "_up" if elevation else ""
    folder = videos / f"render_{motion}_{azimuth:g}deg{up}" / "s"
    linked = folder / "cam01.mp4"
    if linked.is_symlink():
        truth = Truth.load(linked.resolve().parent.parent)
        return folder, truth.times, truth.angles
    samples = default_samples_dir()
    synth = SynthConfig.model_validate({"azimuths_deg": [azimuth], "elevation_deg": elevation,
                                        "start_s": RENDERS[motion],
                                        "length_s": LENGTH_S})  # fmt: skip
    truth = cached_render([Performer(samples / "bvhtools" / "testBvhFiles" / f"{motion}.bvh")],
                          config=synth, mocap=Config().mocap, speech=[samples / s for s in SPEECH],
                          cache=render_cache(samples))  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    for f in truth.videos[0].parent.iterdir():
        if f.suffix in (".mp4", ".wav") and not (folder / f.name).exists():
            (folder / f.name).symlink_to(f)
    return folder, truth.times, truth.angles


def mocap_folders(videos: Path) -> list[tuple[Path, np.ndarray, np.ndarray]]:
    """Every 30 s window of test.bvh as a take folder; (folder, truth times, truth angles)."""
    from dataclasses import replace

    from scipy.io import wavfile

    from gesturebank.footage import SPEECH_RATE, looped_speech
    from gesturebank.mocap.bvh import read_bvh, write_bvh
    from gesturebank.mocap.pose import motion_pose
    from gesturebank.robot.retarget import pepper_angles

    samples = default_samples_dir()
    config = Config()
    motion = read_bvh(samples / "bvhtools" / "testBvhFiles" / "test.bvh")
    per_window = round(WINDOW_S / motion.frame_time)
    out = []
    for a in range(0, len(motion.values), per_window):
        part = replace(motion, values=motion.values[a : a + per_window])
        if len(part.values) < per_window / 2:
            break
        folder = videos / f"mocap_test_{a * motion.frame_time:03.0f}s" / "s"
        folder.mkdir(parents=True, exist_ok=True)
        write_bvh(folder / "test.bvh", part)
        audio = looped_speech([samples / s for s in SPEECH], seconds=WINDOW_S + 1.0)
        wavfile.write(folder / "test.wav", SPEECH_RATE, (audio * 32767).astype(np.int16))
        pose = motion_pose(part, config=config.mocap)[0]
        angles = pepper_angles(pose.joints.astype(np.float64), config=config.retarget)
        out.append((folder, np.asarray(pose.timestamps, float), angles))
    return out


def whole_samples(out: Path, times: np.ndarray, angles: np.ndarray, config: Config) -> Samples:
    """Every stored clip of the whole build, scored against the truth (`times`, `angles`)."""
    dataset = open_dataset(out)
    profile = pepper.load_profile(config.robot.profile)
    parts: list[list[np.ndarray]] = [[], [], [], []]
    for row in (r for r in dataset.rows() if r.clip.kind == "clip"):
        clip = dataset.load(row.clip.clip_id)
        clock = clip.times + clip.start_s
        true = process_angles(raw=angles, timestamps=times, clock=clock,
                              processing=config.processing, retarget=config.retarget,
                              profile=profile)  # fmt: skip
        for k, v in enumerate((clock, clip.angles, true.angles, true.unlimited)):
            parts[k].append(np.asarray(v, np.float64))
    if not parts[0]:
        return Samples(*(np.zeros((0, 11)) for _ in range(4)))
    return Samples(*(np.concatenate(p) for p in parts))


def kept_mask(out: Path, times: np.ndarray) -> tuple[np.ndarray, dict[str, float]]:
    """Which of `times` the re-judged dataset in `out` kept; seconds cut by reason."""
    from gesturebank.qc.stretches import is_cut_reason
    from gesturebank.report.data import reason_kind

    kept = np.zeros(len(times), bool)
    cut: dict[str, float] = {}
    for row in open_dataset(out).rows():
        c = row.clip
        if c.kind == "clip" and c.qc_status == "accepted":
            kept |= (times >= c.start_s - 1e-6) & (times < c.end_s - 1e-6)
        elif c.qc_reasons and (c.kind == "clip" or is_cut_reason(c.qc_reasons[0])):
            kind = reason_kind(c.qc_reasons[0])
            cut[kind] = cut.get(kind, 0.0) + c.end_s - c.start_s
    return kept, cut


def errors(s: Samples, rows: np.ndarray, truth: str) -> tuple[float, float]:
    """(arm MAE °, hand cm) of the samples `rows` against `truth` ("limited" or "person"); the
    hand of each side over the samples whose arm is known (a far arm masked whole at 60°)."""
    if not rows.any():
        return float("nan"), float("nan")
    stored, true = s.stored[rows], getattr(s, truth)[rows]
    per_joint = score_angles(stored, true)[0]
    mine, real = fk(np.nan_to_num(stored)), fk(np.nan_to_num(true))
    gaps = []
    for side, first in (("left", "L"), ("right", "R")):
        arm = [k for k, name in enumerate(JOINTS) if name.startswith(first) and k in ARM_JOINTS]
        known = np.isfinite(stored[:, arm]).all(axis=1) & np.isfinite(true[:, arm]).all(axis=1)
        gaps.append(np.linalg.norm(mine[f"{side}_wrist"] - real[f"{side}_wrist"], axis=1)[known])
    both = np.concatenate(gaps)
    return float(np.nanmean(per_joint[ARM_JOINTS])), 100 * float(both.mean()) if len(
        both
    ) else float("nan")


YAW_BINS = (0, 15, 30, 45, 55, 60, 65, 70, 75, 80, 90, 105, 120, 150, 180.001)  # °


def truth_yaw(folder: Path, times: np.ndarray) -> np.ndarray:
    """(N,) how far the rendered person's torso is turned from the camera at `times` (s of the
    take), degrees 0–180, from the truth beside the render linked in `folder`."""
    from gesturebank.geometry import body_frame
    from gesturebank.skeletons import COCO17
    from gesturebank.synth.truth import Truth

    truth = Truth.load((folder / "cam01.mp4").resolve().parent.parent)
    cam = truth.cameras[0]
    joints = truth.joints3d @ cam.R.T + cam.t  # the camera's frame: the camera at 0
    ls, rs, lh, rh = (joints[:, COCO17.index[n]] for n in
                      ("left_shoulder", "right_shoulder", "left_hip", "right_hip"))  # fmt: skip
    forward, _, up = body_frame(ls, rs, left_hip=lh, right_hip=rh)

    def level(v: np.ndarray) -> np.ndarray:  # v without its part along the torso's up
        v = v - np.sum(v * up, axis=-1, keepdims=True) * up
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    to_camera = -(ls + rs + lh + rh) / 4
    cos = np.clip(np.sum(level(forward) * level(to_camera), axis=-1), -1.0, 1.0)
    return np.interp(times, truth.times, np.degrees(np.arccos(cos)))


def sideways_samples(out: Path, times: np.ndarray) -> np.ndarray:
    """(N,) whether the video frame of each sample of `times` is seen from the side in the 2D
    of the whole build in `out` (`qc.views.sideways`, as QC judges it)."""
    from gesturebank.qc.metrics import judged_points, view_flags

    side = np.zeros(len(times), bool)
    dataset = open_dataset(out)
    for row in (r for r in dataset.rows() if r.clip.kind == "clip"):
        clip = dataset.load(row.clip.clip_id)
        flags = view_flags(judged_points(clip))[1]
        frames = np.asarray(clip.timestamps) + clip.start_s
        k = np.clip(np.searchsorted(frames, times - 1e-6), 0, len(frames) - 1)
        inside = (times >= frames[0] - 1e-6) & (times <= frames[-1] + 1e-6)
        side[inside] = flags[k[inside]]
    return side


def yaw_rows(s: Samples, *, yaw: np.ndarray, side: np.ndarray, kept: np.ndarray) -> list[str]:
    """Lines of the `--by-yaw` table of one take: per bin of `yaw`, the samples, the share
    `side`, arm ° and hand cm; then the yaw of the cut samples."""
    lines = [" yaw °       samples  sideways %  arm °  hand cm"]
    for a, b in itertools.pairwise(YAW_BINS):
        rows = (yaw >= a) & (yaw < b)
        if rows.sum() < 20:  # a fifth of a second: too few to say
            continue
        arm, hand = errors(s, rows, "limited")
        lines.append(f" {a:3.0f}–{b:<4.0f} {rows.sum():9d} {100 * side[rows].mean():11.0f} "
                     f"{arm:6.1f} {hand:8.1f}")  # fmt: skip
    if (~kept).any():
        p = np.percentile(yaw[~kept], [0, 10, 50, 90, 100])
        cut = "min {:.1f}, 10 % {:.1f}, median {:.1f}, 90 % {:.1f}, max {:.1f}".format(*p)
        lines.append(f" cut samples' yaw °: {cut}; kept: median {np.median(yaw[kept]):.1f}")
    return lines


def settings(pairs: list[str]) -> dict:
    """`qc.KEY=VALUE` pairs (JSON values; `none` for None) as a config dict."""
    tree: dict = {}
    for pair in pairs:
        key, value = pair.split("=", 1)
        section, name = key.split(".", 1)
        tree.setdefault(section, {})[name] = None if value == "none" else json.loads(value)
    return tree


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="test.bvh 31–51 s at 60° only")
    ap.add_argument("--mocap", action="store_true", help="test.bvh's 30 s windows, not renders")
    ap.add_argument("--motions", nargs="+", default=list(RENDERS), choices=list(RENDERS))
    ap.add_argument("--azimuths", type=float, nargs="+", help="level cameras at these instead")
    ap.add_argument("--set", nargs="*", default=[], help="qc.KEY=VALUE to re-judge with")
    ap.add_argument("--out", type=Path, help="work folder (kept, builds reused)")
    ap.add_argument("--by-yaw", action="store_true", help="renders: samples by the truth's turn")
    args = ap.parse_args()
    tmp = None if args.out else tempfile.TemporaryDirectory()
    root = Path(args.out or tmp.name)  # type: ignore[union-attr]
    config = Config.model_validate(settings(args.set))
    whole = Config.model_validate({"qc": {"stretch_rounds": 0}})
    if args.mocap:
        takes = mocap_folders(root / "videos")
    else:
        views: tuple[tuple[float, float], ...] = ((60.0, 0.0),) if args.quick else VIEWS
        views = tuple((a, 0.0) for a in args.azimuths) if args.azimuths else views
        motions = ["test"] if args.quick else args.motions
        takes = [render_folder(m, az, el, root / "videos") for m in motions for az, el in views]
    truth_kind = "person" if args.mocap else "limited"
    table = Table(title=f"kept vs all seconds against the {truth_kind} truth "
                  f"({' '.join(args.set) or 'defaults'})")  # fmt: skip
    for col in ("take", "s", "kept %", "arm ° all", "kept", "cut", "hand cm all", "kept", "cut",
                "cut s by reason"):  # fmt: skip
        table.add_column(col, justify="right")
    for folder, times, angles in takes:
        name = folder.parent.name
        built = root / "built" / name
        if not (built / "dataset.json").exists():
            shutil.rmtree(built, ignore_errors=True)
            build_dataset(
                discover_takes(folder.parent), videos_dir=folder.parent, out=built, config=whole
            )
        s = whole_samples(built, times, angles, config)
        judged = root / "judged" / name
        shutil.rmtree(judged, ignore_errors=True)
        shutil.copytree(built, judged)
        refresh(judged, config)
        kept, cut = kept_mask(judged, s.times)
        arm = [errors(s, r, truth_kind)[0] for r in (np.ones_like(kept), kept, ~kept)]
        hand = [errors(s, r, truth_kind)[1] for r in (np.ones_like(kept), kept, ~kept)]
        why = "; ".join(f"{k} {v:.1f}" for k, v in sorted(cut.items(), key=lambda x: -x[1]))
        row = [name, f"{len(s.times) / config.processing.rate_hz:.1f}",
               f"{kept.mean():.0%}" if len(kept) else "-",
               *(f"{v:.1f}" for v in arm), *(f"{v:.1f}" for v in hand), why]  # fmt: skip
        print(" | ".join(row), flush=True)  # as it comes: a full run takes a while
        table.add_row(*row)
        if args.by_yaw and not args.mocap:
            yaw = truth_yaw(folder, s.times)
            lines = yaw_rows(s, yaw=yaw, side=sideways_samples(built, s.times), kept=kept)
            print("\n".join(lines), flush=True)
    Console(width=220).print(table)
    if tmp is not None:
        tmp.cleanup()


if __name__ == "__main__":
    main()
