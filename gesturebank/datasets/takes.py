"""What a take is: finding the videos under VIDEOS_DIR and naming their ids and subjects.

DESIGN.md "What a take is": every video file under VIDEOS_DIR (recursive) is a single-view take;
its id is its relative path with separators made safe. The subject comes from `subjects.csv` at
the root (columns take,subject[,traits…]), else `build.subject_pattern`, else the parent folder.
"""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass, field
from pathlib import Path

from gesturebank.config import BuildConfig
from gesturebank.errors import ConfigError, InputError

SUBJECTS_CSV = "subjects.csv"


@dataclass(frozen=True)
class Take:
    take_id: str
    subject: str
    video: Path
    audio: Path | None = None  # a same-stem .wav replacing the video's own audio track
    traits: dict[str, str] = field(default_factory=dict)


def take_id(relative: Path) -> str:
    """'a/b c/x.mp4' → 'a__b_c__x': unique, filesystem-safe, readable."""
    parts = [re.sub(r"[^A-Za-z0-9._-]+", "_", p) for p in relative.with_suffix("").parts]
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
    rel: Path, tid: str, table: dict[str, dict[str, str]], pattern: str | None
) -> tuple[str, dict[str, str]]:
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
    parent = rel.parent.name
    return (parent or "unknown"), {}


def discover_takes(videos_dir: str | Path, config: BuildConfig | None = None) -> list[Take]:
    """Every video under `videos_dir`, sorted by path. InputError if the folder is missing."""
    config = config or BuildConfig()
    root = Path(videos_dir)
    if not root.is_dir():
        raise InputError(f"{root}: not a directory")
    exts = {e.lower() if e.startswith(".") else f".{e.lower()}" for e in config.video_extensions}
    table = _subjects_csv(root)
    takes: list[Take] = []
    seen: dict[str, Path] = {}
    for path in sorted(p for p in root.rglob("*") if p.is_file() and p.suffix.lower() in exts):
        if any(part.startswith(".") for part in path.relative_to(root).parts):
            continue  # hidden files and folders (partial downloads, caches)
        rel = path.relative_to(root)
        tid = take_id(rel)
        if tid in seen:
            raise InputError(f"{path}: same take id {tid!r} as {seen[tid]}; rename one of them")
        seen[tid] = path
        subject, traits = _subject(rel, tid, table, config.subject_pattern)
        wav = path.with_suffix(".wav")
        takes.append(Take(tid, subject, path, wav if wav.is_file() else None, traits))
    return takes
