"""What a take is: finding the videos under VIDEOS_DIR and naming their ids and subjects.

DESIGN.md "What a take is": every video file under VIDEOS_DIR (recursive) is a single-view take;
its id is its relative path with separators made safe. A folder holding a calibration file
(`calibration.toml` or a Qualisys `*.qca.txt`, itself or in `calibration/`) and two or more
videos (itself or in `videos/`) is one multi-camera take instead, lifted by the multi-view lifter.
The subject comes from `subjects.csv` at the root (columns take,subject[,traits…]), else
`build.subject_pattern`, else the parent folder.
"""

from __future__ import annotations

import csv
import logging
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

from gesturebank.config import BuildConfig
from gesturebank.errors import CalibrationError, ConfigError, InputError

log = logging.getLogger(__name__)

SUBJECTS_CSV = "subjects.csv"
CALIBRATION_NAMES = ("calibration.toml", "*.qca.txt")


@dataclass(frozen=True)
class Take:
    take_id: str
    subject: str
    video: Path  # the video (a multi-camera take: its folder)
    audio: Path | None = None  # a .wav replacing the video's own audio track
    traits: dict[str, str] = field(default_factory=dict)
    videos: tuple[Path, ...] = ()  # a multi-camera take's videos
    calibration: Path | None = None  # a multi-camera take's calibration file

    @property
    def multi_camera(self) -> bool:
        return self.calibration is not None


def take_id(relative: Path, *, folder: bool = False) -> str:
    """'a/b c/x.mp4' → 'a__b_c__x' (a folder keeps its whole name): unique, safe, readable."""
    relative = relative if folder else relative.with_suffix("")
    parts = [re.sub(r"[^A-Za-z0-9._-]+", "_", p) for p in relative.parts]
    return "__".join(parts)


def _subjects_csv(root: Path) -> dict[str, dict[str, str]]:
    path = root / SUBJECTS_CSV
    if not path.is_file():
        return {}
    with open(path, newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        if not {"take", "subject"} <= set(reader.fieldnames or ()):
            raise InputError(f"{path}: needs the columns 'take' and 'subject'")
        rows = list(reader)
    # A row may name the take by its id, its relative path or its file stem.
    return {row["take"].strip(): row for row in rows}


def _subject(
    rel: Path, tid: str, table: dict[str, dict[str, str]], pattern: str | None, folder: str
) -> tuple[str, dict[str, str]]:
    """From subjects.csv, else the pattern, else `folder` (the videos' parent folder)."""
    for key in (tid, rel.as_posix(), rel.stem):
        if key in table:
            row = table[key]
            traits = {k: v for k, v in row.items() if k not in ("take", "subject") and v}
            return row["subject"].strip(), traits
    if pattern:
        try:
            match = re.search(pattern, rel.as_posix())
        except re.error as exc:
            raise ConfigError(
                f"build.subject_pattern: not a valid regular expression ({exc})"
            ) from None
        if match and "subject" in match.groupdict():
            return match.group("subject"), {}
    return (folder or "unknown"), {}


def _files(root: Path) -> list[Path]:
    """Files under `root`, following linked folders (once each), skipping hidden names
    (partial downloads, caches)."""
    found, visited = [], set()
    for folder, dirs, files in os.walk(root, followlinks=True):
        real = os.path.realpath(folder)
        if real in visited:  # a link loop, or the same folder linked twice
            log.warning("%s: same folder as one already searched (%s); skipped", folder, real)
            dirs[:] = []
            continue
        visited.add(real)
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))  # sorted: the first name wins
        found += [Path(folder) / f for f in files if not f.startswith(".")]
    return found


def find_calibration(folder: str | os.PathLike[str]) -> Path:
    """The calibration file of a multi-camera take folder (DESIGN.md "What a take is"):
    `calibration.toml` or a Qualisys `*.qca.txt`, in the folder or its `calibration/` subfolder."""
    root = Path(folder)
    for where in (root, root / "calibration"):
        for pattern in CALIBRATION_NAMES:
            hits = sorted(where.glob(pattern))
            if len(hits) > 1:
                raise CalibrationError(f"{where}: several calibration files ({hits[0].name}, …)")
            if hits:
                return hits[0]
    raise CalibrationError(f"{root}: no calibration.toml or *.qca.txt")


def _camera_folders(videos: list[Path]) -> dict[Path, tuple[Path, list[Path]]]:
    """Folders that form multi-camera takes: {folder: (calibration, its videos)}."""
    groups: dict[Path, list[Path]] = {}
    for video in videos:
        folder = video.parent.parent if video.parent.name == "videos" else video.parent
        groups.setdefault(folder, []).append(video)
    found = {}
    for folder, members in groups.items():
        if len(members) < 2:
            continue
        try:
            found[folder] = (find_calibration(folder), members)
        except CalibrationError as exc:
            if "several calibration files" in str(exc):
                raise InputError(str(exc)) from None
    return found


def discover_takes(videos_dir: str | Path, config: BuildConfig | None = None) -> list[Take]:
    """Every take under `videos_dir` (module docstring), sorted by id. InputError if the folder
    is missing."""
    config = config or BuildConfig()
    root = Path(videos_dir)
    if not root.is_dir():
        raise InputError(f"{root}: not a directory")
    exts = {e.lower() if e.startswith(".") else f".{e.lower()}" for e in config.video_extensions}
    table = _subjects_csv(root)
    videos = sorted(p for p in _files(root) if p.suffix.lower() in exts)
    cameras = _camera_folders(videos)
    in_camera_take = {v for _, members in cameras.values() for v in members}
    takes: list[Take] = []
    seen: dict[str, Path] = {}

    def add(path: Path, rel: Path, **extra: object) -> None:
        is_folder = path.is_dir()
        tid = take_id(rel, folder=is_folder)
        if tid in seen:
            raise InputError(f"{path}: same take id {tid!r} as {seen[tid]}; rename one of them")
        seen[tid] = path
        parent = rel.name if is_folder else rel.parent.name  # the folder holding the videos
        subject, traits = _subject(rel, tid, table, config.subject_pattern, parent)
        takes.append(Take(tid, subject, path, traits=traits, **extra))  # type: ignore[arg-type]

    for path in videos:
        if path not in in_camera_take:
            wav = path.with_suffix(".wav")
            add(path, path.relative_to(root), audio=wav if wav.is_file() else None)
    for folder, (calibration, members) in cameras.items():
        wavs = sorted(folder.glob("*.wav")) + sorted((folder / "videos").glob("*.wav"))
        rel = folder.relative_to(root) if folder != root else Path(root.resolve().name)
        add(
            folder,
            rel,
            audio=wavs[0] if len(wavs) == 1 else None,
            videos=tuple(members),
            calibration=calibration,
        )
    return sorted(takes, key=lambda t: t.take_id)
