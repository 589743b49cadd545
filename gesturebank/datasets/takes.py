"""What a take is: finding the videos under VIDEOS_DIR and naming their ids and subjects.

docs/architecture.md "What a take is": every video file under VIDEOS_DIR (recursive) is a
single-view take;
its id is its relative path with separators made safe and accents transliterated. A folder
holding a calibration file (`calibration.toml` or a Qualisys `*.qca.txt`, itself or in
`calibration/`) and two or more videos (itself or in `videos/`) is one multi-camera take instead,
lifted by the multi-view lifter. A `.bvh` file is a motion-capture take; its audio is the
`.wav` beside it, or the file named in an `audio` column of subjects.csv.
The subject comes from `subjects.csv` at the root (columns take,subject[,traits…]), else
`build.subject_pattern`, else the parent folder; rows that cannot be used as written are
warned about, naming the file and row. The dataset folder is not searched when inside.
"""

from __future__ import annotations

import csv
import difflib
import logging
import os
import re
import unicodedata
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from gesturebank.config import BuildConfig
from gesturebank.errors import CalibrationError, ConfigError, InputError

log = logging.getLogger(__name__)

SUBJECTS_CSV = "subjects.csv"
MOCAP_EXTENSIONS = (".bvh",)  # motion-capture takes: their 3D comes from the file
AUDIO_COLUMN = "audio"  # subjects.csv: a mocap take's audio, relative to the root
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

    @property
    def mocap(self) -> bool:
        """A motion-capture take (`video` is its BVH file)."""
        return self.video.suffix.lower() in MOCAP_EXTENSIONS


def _spelled(part: str) -> str:
    """One path part with accents transliterated (NFKD: 'ünï' → 'uni', NFC and NFD spellings
    alike) and other scripts kept as they are ('日本', 'Привет'), so their names stay distinct.
    Spaces, punctuation and symbols become '_' in `take_id`."""
    out: list[str] = []
    for ch in unicodedata.normalize("NFC", part):
        if unicodedata.combining(ch) and out and out[-1].isascii():
            continue  # an accent NFC could not compose onto its Latin letter
        latin = "".join(
            c for c in unicodedata.normalize("NFKD", ch) if not unicodedata.combining(c)
        )
        if latin and latin.isascii():
            out.append(latin)  # ASCII itself, an accented Latin letter, a full-width form
        elif unicodedata.category(ch)[0] in "LMN":  # a letter, mark or digit of another script
            out.append(ch)
        else:
            out.append(" ")
    return "".join(out)


def take_id(relative: Path, *, folder: bool = False) -> str:
    """'a/b c/x.mp4' → 'a__b_c__x' (a folder keeps its whole name): unique, safe, readable.
    Accented letters are transliterated ('ünï cödé' → 'uni_code'), other scripts kept."""
    relative = relative if folder else relative.with_suffix("")
    parts = [
        re.sub(r"[^A-Za-z0-9._\-\u0080-\U0010ffff]+", "_", _spelled(p)) for p in relative.parts
    ]
    return "__".join(parts)


@dataclass(frozen=True)
class _Row:
    """One row of subjects.csv: its line in the file, subject and traits."""

    line: int
    subject: str
    traits: dict[str, str]


def _subjects_csv(root: Path) -> dict[str, _Row]:
    """subjects.csv by take name (a take id, relative path or file stem); a warning naming the
    file and row for each row that cannot be used as written (a later duplicate wins)."""
    path = root / SUBJECTS_CSV
    if not path.is_file():
        return {}
    table: dict[str, _Row] = {}
    with open(path, newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        if not {"take", "subject"} <= set(reader.fieldnames or ()):
            raise InputError(f"{path}: needs the columns 'take' and 'subject'")
        for row in reader:
            line = reader.line_num
            name, subject = (row.get("take") or "").strip(), (row.get("subject") or "").strip()
            if not name or not subject:
                missing = "take name" if not name else "subject"
                log.warning("%s row %d: no %s; row ignored", path, line, missing)
                continue
            if row.pop(None, None):  # cells beyond the header (csv's restkey)
                log.warning(
                    "%s row %d: more cells than columns; the extra ones ignored", path, line
                )
            if name in table:
                log.warning(
                    "%s row %d: take %r is also on row %d; row %d is used",
                    *(path, line, name, table[name].line, line),
                )
            traits = {k: v for k, v in row.items() if k not in ("take", "subject") and v}
            table[name] = _Row(line, subject, traits)
    return table


def _check_rows(
    root: Path, table: dict[str, _Row], named: dict[str, list[str]], unlisted: list[str]
) -> None:
    """Warn about rows of subjects.csv that name no take or several, and about takes without
    a row. `named`: every name a take answers to → the ids of the takes answering to it."""
    path = root / SUBJECTS_CSV
    for name, row in table.items():
        takes = named.get(name, [])
        if not takes:
            close = difflib.get_close_matches(name, list(named), n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            log.warning("%s row %d: no take is called %r%s", path, row.line, name, hint)
        elif len(takes) > 1:
            log.warning(
                "%s row %d: %r names %d takes (%s); give a take id to name one",
                *(path, row.line, name, len(takes), ", ".join(takes)),
            )
    if table and unlisted:
        shown = ", ".join(unlisted[:3]) + (", …" if len(unlisted) > 3 else "")
        log.warning(
            "%s: no row for %d take(s) (%s); their subject comes from the pattern or folder",
            *(path, len(unlisted), shown),
        )


def _subject(
    rel: Path, row: _Row | None, pattern: str | None, folder: str
) -> tuple[str, dict[str, str]]:
    """From its subjects.csv `row`, else the pattern, else `folder` (the videos' parent)."""
    if row is not None:
        return row.subject, row.traits
    if pattern:
        try:
            match = re.search(pattern, rel.as_posix())
        except re.error as exc:
            raise ConfigError(
                f"build.subject_pattern: not a valid regular expression ({exc})"
            ) from None
        if match and "subject" in match.groupdict():
            return match.group("subject"), {}
    if not folder:  # a video right in the file system's root
        log.warning(
            "%s: no folder name to take a subject from; subject 'unknown' (name one in "
            "subjects.csv or build.subject_pattern)",
            rel,
        )
    return (folder or "unknown"), {}


def _names(rel: Path, tid: str) -> tuple[str, ...]:
    """What a row of subjects.csv may call a take: its id, relative path or file stem."""
    return tuple(dict.fromkeys((tid, rel.as_posix(), rel.stem)))


def _files(root: Path, skip: Path | None = None) -> list[Path]:
    """Files under `root`, following linked folders (once each), skipping hidden names
    (partial downloads, caches) and the folder `skip` (the dataset being written)."""
    found, visited = [], set()
    skipped = os.path.realpath(skip) if skip is not None else None
    if skipped == os.path.realpath(root):  # the dataset written into VIDEOS_DIR itself
        skipped = None
    for folder, dirs, files in os.walk(root, followlinks=True):
        real = os.path.realpath(folder)
        if real in visited:  # a link loop, or the same folder linked twice
            log.warning("%s: same folder as one already searched (%s); skipped", folder, real)
            dirs[:] = []
            continue
        if real == skipped:  # renders of the dataset (e.g. replay --out) are not takes
            log.info("%s: the output folder; not searched for takes", folder)
            dirs[:] = []
            continue
        visited.add(real)
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))  # sorted: the first name wins
        found += [Path(folder) / f for f in files if not f.startswith(".")]
    return found


def find_calibration(folder: str | os.PathLike[str]) -> Path:
    """The calibration file of a multi-camera take folder (docs/architecture.md "What a take is"):
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


def _extensions(config: BuildConfig) -> set[str]:
    return {e.lower() if e.startswith(".") else f".{e.lower()}" for e in config.video_extensions}


def find_inputs(
    inputs: Sequence[str | Path], config: BuildConfig, *, out_dir: str | Path | None = None
) -> tuple[Path, list[Take]]:
    """The takes `build-dataset` is given: one folder (`discover_takes`), or video (and .bvh)
    files, each a single-view take named by its path from their common folder, which is
    returned as the root the dataset's sources are relative to."""
    paths = [Path(p) for p in inputs]
    if len(paths) == 1 and paths[0].is_dir():
        return paths[0], discover_takes(paths[0], config, out_dir=out_dir)
    known = _extensions(config) | set(MOCAP_EXTENSIONS)
    for path in paths:
        if path.is_dir():
            raise InputError(f"{path}: a folder among files; give one folder or only files")
        if not path.is_file():
            raise InputError(f"{path}: no such file or folder")
        if path.suffix.lower() not in known:
            raise InputError(f"{path}: not a video ({', '.join(sorted(known))})")
    root = Path(os.path.commonpath([p.resolve().parent for p in paths]))
    return root, discover_takes(root, config, files=[p.resolve() for p in paths])


def discover_takes(
    videos_dir: str | Path,
    config: BuildConfig | None = None,
    *,
    out_dir: str | Path | None = None,
    files: Sequence[Path] | None = None,
) -> list[Take]:
    """Every take under `videos_dir` (module docstring), sorted by id, leaving out the dataset
    folder `out_dir` when it lies inside. InputError if the folder is missing. `files`: only
    these files under it, each its own take (no multi-camera folders; a file right in
    `videos_dir` takes its folder's name as subject)."""
    config = config or BuildConfig()
    root = Path(videos_dir)
    if not root.is_dir():
        raise InputError(f"{root}: not a directory; give a folder of videos or video files")
    exts = _extensions(config)
    table = _subjects_csv(root)
    skip = Path(out_dir) if out_dir is not None else None
    candidates = _files(root, skip) if files is None else list(files)
    videos = sorted(p for p in candidates if p.suffix.lower() in exts)
    cameras = _camera_folders(videos) if files is None else {}
    in_camera_take = {v for _, members in cameras.values() for v in members}
    takes: list[Take] = []
    seen: dict[str, Path] = {}
    named: dict[str, list[str]] = {}  # every name a take answers to in subjects.csv → take ids
    unlisted: list[str] = []  # takes without a row

    def add(path: Path, rel: Path, **extra: object) -> None:
        is_folder = path.is_dir()
        tid = take_id(rel, folder=is_folder)
        if tid in seen:
            raise InputError(f"{path}: same take id {tid!r} as {seen[tid]}; rename one of them")
        seen[tid] = path
        parent = rel.name if is_folder else rel.parent.name  # the folder holding the videos
        if not parent:  # right in VIDEOS_DIR (a flat folder): that folder's own name
            parent = path.resolve().parent.name
        rows = [table[n] for n in _names(rel, tid) if n in table]
        if len(rows) > 1:
            log.warning(
                "%s rows %s name the same take %s; row %d is used (id > path > file stem)",
                *(root / SUBJECTS_CSV, " and ".join(str(r.line) for r in rows), tid, rows[0].line),
            )
        if table and not rows:
            unlisted.append(tid)
        for name in _names(rel, tid):
            named.setdefault(name, []).append(tid)
        subject, traits = _subject(rel, rows[0] if rows else None, config.subject_pattern, parent)
        takes.append(Take(tid, subject, path, traits=traits, **extra))  # type: ignore[arg-type]

    for path in videos:
        if path not in in_camera_take:
            wav = path.with_suffix(".wav")
            add(path, path.relative_to(root), audio=wav if wav.is_file() else None)
    for path in sorted(p for p in candidates if p.suffix.lower() in MOCAP_EXTENSIONS):
        wav = path.with_suffix(".wav")
        add(path, path.relative_to(root), audio=wav if wav.is_file() else None)
        listed = takes[-1].traits.get(AUDIO_COLUMN)
        if listed:  # the audio named in subjects.csv, not a trait of the subject
            traits = {k: v for k, v in takes[-1].traits.items() if k != AUDIO_COLUMN}
            takes[-1] = replace(takes[-1], audio=root / listed, traits=traits)
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
    _check_rows(root, table, named, sorted(unlisted))
    return sorted(takes, key=lambda t: t.take_id)
