"""`gesturebank stimuli`: blind stimulus videos of Pepper for a perceptual study.

For each speech source — an audio file (`--audio A.wav`) or a dataset clip (`--clip
DATASET:CLIP_ID`, whose audio is cut from its source video) — one video per condition: every
model's motion (offline synthesis, `train.synthesis.synthesize`), every other system's angle
timelines (`--timelines DIR`: one file per speech source, `<name>.csv` or the `.jsonl` a record
backend writes, in any dialect `robot.timeline` reads), the ground truth (clips only: the clip's
own angles), and an anchor (`mean-pose`: the first model's training mean pose,
held still; `random-clip`: another clip of the first model's dataset, chosen by a seed). Every
video of one source has the same camera (`[render]`), the same duration (the audio's) and the
audio muxed; motion is made safe as replay makes it (clamp and speed limit), without the safety
moves. Videos are named by random ids, so neither a file name nor the manifest gives a condition
away; only the key says which is which.

Layout of the study folder:

    videos/<id>.mp4     one stimulus (H.264 + AAC)
    posters/<id>.jpg    its poster frame (the middle frame), shown before it is played
    audio/<name>.wav    the speech of each clip source (16 kHz mono), as muxed
    motion/<id>.csv     the angles the video shows (an angle timeline, after the player's
                        safety), for the operator; the study app does not serve it
    stimuli.json        the manifest, for the study app and participants' pages — no conditions
    key.json            id → condition, model folder, speech source: for the operator only

stimuli.json (format "gesturebank-stimuli/1"):

    {"format": "gesturebank-stimuli/1",
     "fps": 25, "width_px": 640, "height_px": 480,
     "groups": [{"audio": "<name>", "duration_s": 3.52,
                 "videos": [{"id": "<id>", "file": "videos/<id>.mp4"}, ...]}, ...]}

One group per speech source, in the order given; its videos in random order. `audio` is the
source's name (the audio file's stem, or the clip id), unique within the file.

key.json (format "gesturebank-stimuli-key/1"):

    {"format": "gesturebank-stimuli-key/1",
     "videos": {"<id>": {"audio": "<name>", "condition": "<model name>" | "ground-truth" |
                          "anchor", "role": "model" | "reference" | "anchor",
                          "model_dir": "<path>" | null, "timelines": "<path>" | null,
                          "source": "<audio path or DATASET:CLIP>",
                          "anchor": "mean-pose" | "random-clip" | null}}}

Model names are the model folders' and timeline folders' names (with the parent's when two
clash), as `compare` names them; a timeline folder's system has the role "model". In MUSHRA
terms the ground truth is the hidden reference and the anchor the anchor.
"""

from __future__ import annotations

import json
import os
import secrets
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from gesturebank.config import PlaybackConfig, RenderConfig
from gesturebank.datasets.listing import clip_timeline
from gesturebank.errors import InputError
from gesturebank.fileio import write_bytes_atomic
from gesturebank.robot import pepper
from gesturebank.robot.safety import safe_angles, speed_profile
from gesturebank.robot.timeline import Timeline, read_timeline, write_timeline

PathLike = str | os.PathLike[str]
Anchor = Literal["mean-pose", "random-clip"]
ANCHORS: tuple[Anchor, ...] = ("mean-pose", "random-clip")
FORMAT, KEY_FORMAT = "gesturebank-stimuli/1", "gesturebank-stimuli-key/1"
MANIFEST, KEY = "stimuli.json", "key.json"
_RATE = 16000
TIMELINE_SUFFIXES = (".csv", ".jsonl")  # a system's timeline of one speech; the first found


@dataclass(frozen=True)
class Source:
    """One speech source: `audio` (a file to mux) and, for a dataset clip, where it came from."""

    name: str
    audio: Path
    label: str  # as the user gave it: the audio path or DATASET:CLIP_ID
    dataset: Path | None = None
    clip_id: str | None = None


def parse_clip(spec: str) -> tuple[Path, str]:
    """'DATASET:CLIP_ID' → (dataset folder, clip id); InputError when malformed."""
    folder, sep, clip = spec.rpartition(":")
    if not sep or not folder or not clip:
        raise InputError(f"--clip {spec!r}: expected DATASET_DIR:CLIP_ID")
    return Path(folder), clip


def _clip_audio(dataset: Path, clip_id: str, out: Path) -> tuple[str, Path]:
    """Cut the clip's stretch of its source's audio into `out` (16 kHz mono WAV), as `replay
    --clip` plays it; returns the clip id (`clip_id` may name a take of one clip) and `out`."""
    from gesturebank import datasets
    from gesturebank.datasets.listing import resolve_clip, source_media, write_clip_audio

    ds = datasets.open(dataset)
    row = resolve_clip(ds, clip_id)
    out.parent.mkdir(parents=True, exist_ok=True)
    wav = write_clip_audio(ds, row, out=out, sample_rate=_RATE)
    if wav is None:
        source = source_media(ds, row) or Path(ds.info.videos_dir) / row.source
        raise InputError(f"{source}: no audio for clip {row.clip_id} (gone, or no audio track)")
    return row.clip_id, wav


def _duration(audio: Path) -> float:
    from gesturebank.audio.io import read_audio

    track = read_audio(audio, sample_rate=_RATE)
    if track is None or not len(track.signal):
        raise InputError(f"{audio}: no audio track")
    return len(track.signal) / _RATE


def _sources(audios: Sequence[PathLike], clips: Sequence[str], out: Path) -> list[Source]:
    found: list[Source] = []
    for a in audios:
        path = Path(a)
        if not path.is_file():
            raise InputError(f"{path}: no such audio file")
        found.append(Source(path.stem, path, os.fspath(path)))
    for spec in clips:
        dataset, name = parse_clip(spec)
        clip_id, wav = _clip_audio(dataset, name, out / "audio" / f"{name}.wav")
        found.append(Source(clip_id, wav, spec, dataset, clip_id))
    names = [s.name for s in found]
    clash = sorted({n for n in names if names.count(n) > 1})
    if clash:
        raise InputError(f"speech sources with the same name: {', '.join(clash)}; rename one")
    if not found:
        raise InputError("stimuli needs at least one --audio or --clip")
    return found


def _system_timeline(folder: Path, source: str, profile: str) -> Timeline:
    """`folder`'s timeline of speech `source`; InputError (one line, naming the file) when it is
    missing, unreadable or for another robot profile (one that names none is taken as ours)."""
    if not folder.is_dir():
        raise InputError(f"{folder}: not a folder of angle timelines (--timelines)")
    path = next(
        (p for s in TIMELINE_SUFFIXES if (p := folder / f"{source}{s}").is_file()),
        folder / f"{source}{TIMELINE_SUFFIXES[0]}",
    )
    if not path.is_file():
        raise InputError(
            f"{path}: no timeline for speech {source} (one file per speech, named by its "
            "audio's stem or clip id)"
        )
    line = read_timeline(path)
    if line.profile is not None and line.profile != profile:
        raise InputError(
            f"{path}: angles for robot profile {line.profile}; the study's is {profile}"
        )
    return line


def _hold(pose: np.ndarray, duration: float, rate_hz: float = 100.0) -> Timeline:
    n = max(1, round(duration * rate_hz))
    return Timeline.of(np.arange(n) / rate_hz, np.tile(pose, (n, 1)))


def _cut(timeline: Timeline, duration: float) -> Timeline:
    """The part before `duration` s (at least the first frame)."""
    keep = max(1, int(np.searchsorted(timeline.times, duration, side="left")))
    return Timeline.of(timeline.times[:keep], timeline.angles[:keep])


def _random_clip(dataset: Path, avoid: set[str], rng: np.random.Generator) -> Timeline:
    from gesturebank import datasets

    ids = [c for c in datasets.open(dataset).clip_ids() if c not in avoid]
    if not ids:
        raise InputError(f"{dataset}: no other accepted clip for the random-clip anchor")
    return clip_timeline(dataset, ids[int(rng.integers(len(ids)))])


def stimuli_command(
    *,
    model_dirs: Sequence[PathLike],
    out: PathLike,
    audios: Sequence[PathLike] = (),
    timelines: Sequence[PathLike] = (),
    clips: Sequence[str] = (),
    anchor: Anchor = "mean-pose",
    anchor_seed: int = 0,
    render: RenderConfig | None = None,
    playback: PlaybackConfig | None = None,
    profile: str | None = None,
) -> dict[str, Any]:
    """Render the stimuli into the study folder `out`; returns the manifest written.

    `timelines`: folders of other systems' angle timelines, one condition each. `anchor_seed`
    picks the random-clip anchor and the order of each group's videos; the ids are random every
    run (`secrets`).
    """
    from gesturebank.robot.render import write_video
    from gesturebank.study.posters import poster_path, write_poster
    from gesturebank.train import model_folder
    from gesturebank.train.eval.compare import model_names
    from gesturebank.train.synthesis import synthesize

    if not model_dirs:
        raise InputError("stimuli needs at least one model folder")
    if anchor not in ANCHORS:
        raise InputError(f"--anchor {anchor!r}: one of {', '.join(ANCHORS)}")
    cfg, play = render or RenderConfig(), playback or PlaybackConfig()
    root = Path(out)
    folders = [model_folder.load(d) for d in model_dirs]
    robot = speed_profile(
        pepper.load_profile(profile) if profile else folders[0].profile, play.max_speed_fraction
    )
    sources = _sources(audios, clips, root)
    rng = np.random.default_rng(anchor_seed)
    mean_pose = pepper.denormalise(
        np.asarray(folders[0].norm["mean_pose01"]).reshape(1, -1), folders[0].profile
    )[0]
    names = model_names([*map(Path, model_dirs), *map(Path, timelines)])
    shown_profile = robot.name
    groups: list[dict[str, Any]] = []
    key: dict[str, dict[str, Any]] = {}
    used: set[str] = set()
    with tempfile.TemporaryDirectory(prefix=".stimuli-", dir=_parent(root)) as tmp:
        for src in sources:
            duration = _duration(src.audio)
            conditions: list[tuple[str, str, str | None, str | None, Timeline]] = []
            for name, model_dir in zip(names[: len(model_dirs)], model_dirs, strict=True):
                csv = Path(tmp) / f"{len(key) + len(conditions)}.csv"
                synthesize(model_dir=model_dir, audio_path=src.audio, out_csv=csv)
                line = read_timeline(csv)
                conditions.append((name, "model", os.fspath(model_dir), None, line))
            for name, system_dir in zip(names[len(model_dirs) :], timelines, strict=True):
                line = _system_timeline(Path(system_dir), src.name, shown_profile)
                conditions.append((name, "model", None, os.fspath(system_dir), line))
            if src.dataset is not None and src.clip_id is not None:
                truth = clip_timeline(src.dataset, src.clip_id)
                conditions.append(("ground-truth", "reference", None, None, truth))
            if anchor == "mean-pose":
                still = _hold(mean_pose, duration)
            else:
                dataset = src.dataset or Path(folders[0].info.need(folders[0].path, "dataset"))
                still = _random_clip(dataset, {src.clip_id or ""}, rng)
            conditions.append(("anchor", "anchor", None, None, still))
            videos = []
            for condition, role, folder, system, timeline in conditions:
                vid = _new_id(used)
                tl = _cut(timeline, duration)
                shown = safe_angles(tl, robot)
                write_timeline(
                    root / "motion" / f"{vid}.csv",
                    Timeline.of(tl.times, shown, profile=shown_profile, reach=tl.reach),
                )
                write_video(
                    [("", tl.times, shown)],
                    root / "videos" / f"{vid}.mp4",
                    duration=duration,
                    audio=src.audio,
                    render=cfg,
                )
                write_poster(root / "videos" / f"{vid}.mp4", poster_path(root, vid))
                videos.append({"id": vid, "file": f"videos/{vid}.mp4"})
                key[vid] = {
                    "audio": src.name,
                    "condition": condition,
                    "role": role,
                    "model_dir": folder,
                    "timelines": system,
                    "source": src.label,
                    "anchor": anchor if role == "anchor" else None,
                }
            order = rng.permutation(len(videos))
            groups.append(
                {
                    "audio": src.name,
                    "duration_s": round(duration, 3),
                    "videos": [videos[i] for i in order],
                }
            )
    manifest = {
        "format": FORMAT,
        "fps": cfg.frame_rate,
        "width_px": cfg.width_px,
        "height_px": cfg.height_px,
        "groups": groups,
    }
    _write_json(root / KEY, {"format": KEY_FORMAT, "videos": key})
    _write_json(root / MANIFEST, manifest)
    return manifest


def _parent(root: Path) -> Path:
    root.mkdir(parents=True, exist_ok=True)
    return root


def _new_id(used: set[str]) -> str:
    while True:
        vid = secrets.token_hex(5)
        if vid not in used:
            used.add(vid)
            return vid


def _write_json(path: Path, data: dict[str, Any]) -> None:
    write_bytes_atomic(path, (json.dumps(data, indent=2) + "\n").encode("utf-8"))
