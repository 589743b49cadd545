"""Render BVH motion as a take with its exact truth (layout: `synth.truth`), cached by checksum.

`render_take` reads each performer's BVH with the project's own reader (`mocap.bvh`,
`mocap.pose`: COCO-17 metres), cuts the stretch of `[synth]` and resamples it to the video's
frame times (linear), places the figures (the first one stands where its file puts it, the
others at offsets in its axes), sets the cameras around the first figure (`synth.camera`),
renders one video per camera with the speech muxed, and writes the truth. A folder already
holding the render of the same inputs (BVH bytes, speech bytes, options, `VERSION`; recorded in
render.json) is left as it is.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np

from gesturebank.camera_files import CameraGroup
from gesturebank.config import MocapConfig, RetargetConfig, SynthConfig, SynthLook
from gesturebank.errors import InputError
from gesturebank.fileio import atomic_open, sha256_file, write_bytes_atomic
from gesturebank.footage import ENCODER, SPEECH_RATE, looped_speech
from gesturebank.mocap.bvh import read_bvh
from gesturebank.mocap.pose import motion_pose
from gesturebank.robot.retarget import pepper_angles
from gesturebank.synth.camera import Stage, orbit_camera, stage_of
from gesturebank.synth.looks import LOOKS
from gesturebank.synth.raycast import Figure, render_frames
from gesturebank.synth.truth import KEY, SPEECH, VIDEOS, Truth
from gesturebank.synth.video import write_stream

# Part of every render's cache key, with the renderer's own source (`code_digest`): bump it
# when a render changes for a reason outside these files.
VERSION = 1
# The modules whose code decides what a render looks like.
RENDERER = ("camera", "figure", "looks", "raycast", "take", "video")


def code_digest() -> str:
    """sha256 of the renderer's source: an edit to it makes every cached render stale."""
    folder = Path(__file__).parent
    h = hashlib.sha256()
    for name in RENDERER:
        h.update((folder / f"{name}.py").read_bytes())
    return h.hexdigest()


@dataclass(frozen=True, eq=False)
class Performer:
    """One figure of a scene.

    bvh: its motion; offset_m: (forward, left, up) metres from where its file puts it, in the
    first performer's axes (the first performer's own offset moves it too); turn_deg: turned
    about the vertical through its middle (positive: towards its left); mouth: (T,) opening in
    [0, 1] per video frame (None: closed); look: None takes `[synth] look`.
    """

    bvh: Path
    offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    turn_deg: float = 0.0
    mouth: np.ndarray | None = None
    look: SynthLook | None = None


def rig_azimuths(*, centre_deg: float, count: int, spread_deg: float) -> list[float]:
    """`count` camera directions spread evenly over `spread_deg`, centred on `centre_deg`."""
    if count < 1:
        raise ValueError(f"a rig needs at least one camera, got {count}")
    if count == 1:
        return [centre_deg]
    return [float(a) for a in centre_deg + np.linspace(-spread_deg / 2, spread_deg / 2, count)]


def stretch(bvh: Path, *, config: SynthConfig, mocap: MocapConfig) -> tuple[np.ndarray, np.ndarray]:
    """Video frame times (T,) s from the stretch's start and the COCO-17 joints (T, 17, 3)
    metres at those times (linear between BVH frames). InputError naming the file."""
    motion = read_bvh(bvh)
    pose, _ = motion_pose(motion, config=mocap, source=os.fspath(bvh))
    joints = np.asarray(pose.joints, np.float64)
    source_times = np.asarray(pose.timestamps, np.float64)
    end = source_times[-1]
    if config.start_s > end:
        raise InputError(f"{bvh}: starts at {config.start_s} s, but the motion ends at {end:.2f} s")
    length = end - config.start_s if config.length_s is None else config.length_s
    if config.start_s + length > end + 1e-6:
        raise InputError(
            f"{bvh}: {length} s from {config.start_s} s goes past the motion's end at {end:.2f} s"
        )
    count = int(np.floor(length * config.rate_fps + 1e-6))
    if count < 1:
        raise InputError(f"{bvh}: {length} s is less than one frame at {config.rate_fps} fps")
    times = np.arange(count) / config.rate_fps
    at = config.start_s + times
    flat = joints.reshape(len(joints), -1)
    sampled = np.stack([np.interp(at, source_times, flat[:, k]) for k in range(flat.shape[1])], 1)
    sampled = sampled.reshape(count, *joints.shape[1:])
    if not np.isfinite(sampled).all():
        raise InputError(f"{bvh}: some COCO-17 joints are missing from the skeleton")
    return times, sampled


def place(joints: np.ndarray, *, stage: Stage, offset_m: Sequence[float], turn_deg: float):
    """`joints` (T, 17, 3) turned about the stage's vertical through their own middle, then
    moved by `offset_m` (forward, left, up) in the stage's axes."""
    up = stage.up
    middle = joints.reshape(-1, 3).mean(axis=0)
    a = np.radians(turn_deg)
    # Rodrigues' rotation about `up` by a.
    k = np.array([[0, -up[2], up[1]], [up[2], 0, -up[0]], [-up[1], up[0], 0]])
    rotation = np.eye(3) + np.sin(a) * k + (1 - np.cos(a)) * k @ k
    moved = (joints - middle) @ rotation.T + middle
    forward, left, lift = offset_m
    return moved + forward * stage.forward + left * stage.left + lift * stage.up


def _digest(array: np.ndarray | None) -> str | None:
    if array is None:
        return None
    return hashlib.sha256(np.ascontiguousarray(array, np.float64).tobytes()).hexdigest()


def render_key(
    performers: Sequence[Performer],
    *,
    config: SynthConfig,
    mocap: MocapConfig,
    speech: Sequence[Path],
) -> dict[str, object]:
    """What a render is made of: its cache key (JSON-ready)."""
    return json.loads(
        json.dumps(
            {
                "version": VERSION,
                "code": code_digest(),
                "encoder": ENCODER,
                "synth": config.model_dump(mode="json"),
                "mocap": mocap.model_dump(mode="json"),
                "performers": [
                    {
                        "bvh": sha256_file(p.bvh),
                        "offset_m": list(p.offset_m),
                        "turn_deg": p.turn_deg,
                        "mouth": _digest(p.mouth),
                        "look": p.look,
                    }
                    for p in performers
                ],
                "speech": [sha256_file(s) for s in speech],
            }
        )
    )


def _read_key(folder: Path) -> object:
    try:
        return json.loads((folder / KEY).read_text())
    except (OSError, ValueError):
        return None


def _check_wav(path: Path) -> None:
    """InputError naming `path` unless it is a readable WAV file."""
    from scipy.io import wavfile

    if not path.is_file():
        raise InputError(f"{path}: speech file not found")
    try:
        wavfile.read(path, mmap=True)
    except (ValueError, OSError) as exc:
        raise InputError(f"{path}: not a readable WAV file ({exc})") from None


def render_take(
    performers: Sequence[Performer],
    out: Path,
    *,
    config: SynthConfig,
    mocap: MocapConfig,
    speech: Sequence[Path],
) -> Truth:
    """Render the performers into the folder `out` (layout: `synth.truth`) unless it already
    holds this render; returns its truth."""
    if not performers:
        raise ValueError("render_take: no performers")
    for p in performers:
        if not Path(p.bvh).is_file():
            raise InputError(f"{p.bvh}: BVH file not found")
    for s in speech:
        _check_wav(Path(s))
    key = render_key(performers, config=config, mocap=mocap, speech=speech)
    out = Path(out)
    if _read_key(out) == key:
        try:
            truth = Truth.load(out)
            if all(v.is_file() for v in truth.videos):
                return truth
        except InputError:
            pass
    (out / KEY).unlink(missing_ok=True)  # a render killed mid-way must not look finished

    times = None
    placed: list[np.ndarray] = []
    stage = None
    for p in performers:
        t, joints = stretch(Path(p.bvh), config=config, mocap=mocap)
        if times is not None and len(t) != len(times):
            raise InputError(f"{p.bvh}: {len(t)} frames, the first performer has {len(times)}")
        times = t
        stage = stage or stage_of(joints)
        placed.append(place(joints, stage=stage, offset_m=p.offset_m, turn_deg=p.turn_deg))
    assert times is not None and stage is not None
    count = len(times)
    mouths = []
    for p in performers:
        mouth = np.zeros(count) if p.mouth is None else np.asarray(p.mouth, np.float64)
        if mouth.shape != (count,):
            raise InputError(f"{p.bvh}: mouth has {mouth.shape}, the video {count} frames")
        mouths.append(np.clip(mouth, 0, 1))
    figures = [
        Figure(joints, mouth, LOOKS[p.look or config.look])
        for joints, mouth, p in zip(placed, mouths, performers, strict=True)
    ]
    # Cameras around the figures' mean chest, facing the first one's front.
    stage = Stage(
        target=stage_of(np.concatenate(placed, 0)).target, forward=stage.forward, up=stage.up
    )
    size = (config.width_px, config.height_px)
    cameras = CameraGroup(
        [
            orbit_camera(
                stage,
                name=f"cam{i + 1:02d}",
                azimuth_deg=az,
                elevation_deg=config.elevation_deg,
                distance_m=config.distance_m,
                fov_deg=config.fov_deg,
                size=size,
            )
            for i, az in enumerate(config.azimuths_deg)
        ]
    )
    fps = Fraction(config.rate_fps).limit_denominator(1001)
    try:
        audio = looped_speech(list(speech), seconds=count / config.rate_fps)
    except ValueError as exc:  # names the file: not 16 kHz mono 16-bit
        raise InputError(str(exc)) from None
    scenery = LOOKS[config.look]
    for camera in cameras:
        frames = render_frames(figures, camera, scenery=scenery, supersample=config.supersample)
        write_stream(
            frames,
            out / VIDEOS / f"{camera.name}.mp4",
            size=size,
            fps=fps,
            count=count,
            speech=audio,
        )
    from scipy.io import wavfile

    with atomic_open(out / SPEECH) as f:
        wavfile.write(f, SPEECH_RATE, np.round(audio * 32767).astype(np.int16))
    first = placed[0]
    truth = Truth(
        folder=out,
        times=times,
        joints3d=first,
        figures3d=np.stack(placed),
        angles=pepper_angles(first, config=RetargetConfig()),
        joints2d=np.stack([cam.project(first) for cam in cameras]),
        mouth=np.stack(mouths),
        cameras=cameras,
        fps=config.rate_fps,
        start_s=config.start_s,
        source=tuple(Path(p.bvh).name for p in performers),
        look=config.look,
    )
    truth.save()
    write_bytes_atomic(out / KEY, json.dumps(key, indent=1).encode())
    return truth


def render_cache(samples: Path) -> Path:
    """Where renders are cached: beside the samples folder, as `footage` keeps its takes."""
    return samples.parent / "synth"


def cached_folder(
    performers: Sequence[Performer],
    *,
    config: SynthConfig,
    mocap: MocapConfig,
    speech: Sequence[Path],
    cache: Path,
) -> Path:
    """`cache/<checksum of the render's key>`: where `cached_render` puts this render."""
    key = render_key(performers, config=config, mocap=mocap, speech=speech)
    return cache / hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:16]


def cached_render(
    performers: Sequence[Performer],
    *,
    config: SynthConfig,
    mocap: MocapConfig,
    speech: Sequence[Path],
    cache: Path,
) -> Truth:
    """`render_take` into `cached_folder(...)` (e.g. under `render_cache(samples)`), so the
    same render is made once however many tests and benchmarks ask for it."""
    folder = cached_folder(performers, config=config, mocap=mocap, speech=speech, cache=cache)
    return render_take(performers, folder, config=config, mocap=mocap, speech=speech)
