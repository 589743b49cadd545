"""Finding a dataset's clips: the rows `gesturebank clips` lists, the id `replay --clip` means,
and the source audio and the angle timeline that go with a clip.

A clip is named by its id (`<take id>__c000`); a take id names its clip when the take has only
one. A wrong name is answered with the nearest ids (difflib), one line.
"""

from __future__ import annotations

import csv
import difflib
import io
import os
import wave
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gesturebank.datasets.manifest import take_records
from gesturebank.datasets.reader import Dataset, ManifestRow
from gesturebank.datasets.records import STATUSES, Status
from gesturebank.errors import InputError
from gesturebank.qc.stretches import is_cut_reason

if TYPE_CHECKING:
    from gesturebank.robot.timeline import Timeline

# The robot's body parts, by the joints that move them (`pepper.JOINTS` names).
PARTS = {
    "head": ("HeadPitch", "HeadYaw"),
    "left arm": ("LShoulderPitch", "LShoulderRoll", "LElbowYaw", "LElbowRoll"),
    "right arm": ("RShoulderPitch", "RShoulderRoll", "RElbowYaw", "RElbowRoll"),
    "hip": ("HipRoll",),
}
COLUMNS = ("clip", "take", "subject", "start_s", "end_s", "seconds", "status", "reasons", "masked")
MAX_SUGGESTIONS = 3


@dataclass(frozen=True)
class ClipRow:
    """One clip with arrays, as listed: where it lies in its source video (start_s, end_s),
    its length (seconds of its 100 Hz clock), the QC's verdict, and the share of its frames in
    which each body part is unknown (`masked`, parts never unknown left out)."""

    clip_id: str
    take_id: str
    subject: str
    source: str
    start_s: float
    end_s: float
    seconds: float
    status: Status
    reasons: tuple[str, ...]
    masked: dict[str, float]

    def masked_text(self) -> str:
        """e.g. "left arm 43%" (the share of frames it is unknown in); empty when none."""
        return ", ".join(f"{part} {share:.0%}" for part, share in self.masked.items())

    def cells(self) -> tuple[str, ...]:
        """The row as text, in `COLUMNS` order."""
        return (
            self.clip_id,
            self.take_id,
            self.subject,
            f"{self.start_s:.3f}",
            f"{self.end_s:.3f}",
            f"{self.seconds:.2f}",
            self.status,
            "; ".join(self.reasons),
            self.masked_text(),
        )


def _row(r: ManifestRow) -> ClipRow:
    joints = r.clip.masked
    masked = {
        part: share
        for part, names in PARTS.items()
        if (share := max(float(joints.get(j, 0.0)) for j in names)) > 0
    }
    return ClipRow(
        r.clip.clip_id,
        r.take.take_id,
        r.take.subject,
        r.take.source,
        r.clip.start_s,
        r.clip.end_s,
        r.clip.duration_s,
        r.clip.qc_status,
        r.clip.qc_reasons,
        masked,
    )


def list_clips(
    data: Dataset,
    *,
    status: Status | None = None,
    subject: str | None = None,
    take: str | None = None,
) -> list[ClipRow]:
    """The clips with arrays of `data` in manifest order, those given filters keep; with status
    "rejected" also the stretches the QC cut out of clips (`cut_stretches`), the rows
    then by take and time. An unknown
    subject or take is an InputError naming the nearest ones."""
    rows = [_row(r) for r in data.clips(None)]
    if status is not None and status not in STATUSES:
        raise InputError(f"--status {status!r}: one of {', '.join(STATUSES)}")
    for flag, value, known in (
        ("--subject", subject, {r.subject for r in rows}),
        ("--take", take, {r.take_id for r in rows}),
    ):
        if value is not None and value not in known:
            raise InputError(f"{data.path}: no {flag[2:]} {value!r}{_nearest(value, known)}")
    if status == "rejected":  # the stretches the QC cut out of clips too
        rows = sorted([*rows, *cut_stretches(data)], key=lambda r: (r.take_id, r.start_s))
    return [
        r
        for r in rows
        if (status is None or r.status == status)
        and (subject is None or r.subject == subject)
        and (take is None or r.take_id == take)
    ]


def cut_stretches(data: Dataset) -> list[ClipRow]:
    """The stretches the QC cut out of clips (issue 41: spans of the take records whose reason
    is `qc.stretches.is_cut_reason`), as rows with status "rejected" and no arrays."""
    rows = []
    for record in take_records(data.path):
        for c in record.clips:
            if c.kind == "span" and c.qc_reasons and is_cut_reason(c.qc_reasons[0]):
                rows.append(
                    ClipRow(
                        c.clip_id,
                        record.take_id,
                        record.subject,
                        record.source,
                        c.start_s,
                        c.end_s,
                        c.end_s - c.start_s,
                        "rejected",
                        c.qc_reasons,
                        {},
                    )
                )
    return rows


def _nearest(name: str, known: set[str] | list[str]) -> str:
    near = difflib.get_close_matches(name, sorted(known), n=MAX_SUGGESTIONS, cutoff=0.5)
    return f"; did you mean {' or '.join(near)}?" if near else ""


def resolve_clip(data: Dataset, name: str) -> ClipRow:
    """The clip `name` means: a clip id, or a take id whose take has one clip. InputError (one
    line) listing a take's clips when it has several, or suggesting the nearest ids."""
    rows = [_row(r) for r in data.clips(None)]
    by_id = {r.clip_id: r for r in rows}
    if name in by_id:
        return by_id[name]
    of_take = [r for r in rows if r.take_id == name]
    if len(of_take) == 1:
        return of_take[0]
    if of_take:
        ids = ", ".join(r.clip_id for r in of_take)
        raise InputError(f"{data.path}: take {name!r} has {len(of_take)} clips: {ids}; pick one")
    takes = {r.take_id for r in rows}
    hint = _nearest(name, set(by_id) | takes) or (
        f"; `gesturebank clips {data.path}` lists them" if rows else ""
    )
    raise InputError(f"{data.path}: no clip or take {name!r} in the manifest{hint}")


def source_media(data: Dataset, row: ClipRow) -> Path | None:
    """The file holding the clip's sound: the .wav beside its video (or in its camera folder),
    else the video itself; None when the source is no longer where the build found it."""
    source = Path(data.info.videos_dir) / row.source
    if source.is_dir():  # a multi-camera take: its wav, else its first video
        wavs = sorted(source.glob("*.wav")) + sorted(source.glob("videos/*.wav"))
        exts = {
            e if e.startswith(".") else f".{e}" for e in data.info.config.build.video_extensions
        }
        videos = sorted(p for p in source.rglob("*") if p.suffix.lower() in exts)
        found = wavs[:1] or videos[:1]
        return found[0] if found else None
    wav = source.with_suffix(".wav")
    if wav.is_file():
        return wav
    return source if source.is_file() else None


def write_clip_audio(
    data: Dataset, row: ClipRow, *, out: str | os.PathLike[str], sample_rate: int
) -> Path | None:
    """The clip's stretch of its source audio (from clip time 0 on the source's clock) as a
    16-bit mono WAV at `out`; None when the source is missing or has no audio track."""
    from gesturebank.audio.io import read_audio

    media = source_media(data, row)
    if media is None:
        return None
    track = read_audio(media, sample_rate=sample_rate)
    if track is None:
        return None
    first = max(0, round((row.start_s - track.start_s) * sample_rate))
    last = max(first, round((row.start_s - track.start_s + row.seconds) * sample_rate))
    piece = np.clip(track.signal[first:last], -1.0, 1.0)
    path = Path(out)
    with wave.open(os.fspath(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(sample_rate)
        w.writeframes((piece * 32767).astype("<i2").tobytes())
    return path


def rows_csv(rows: list[ClipRow]) -> str:
    """The rows as CSV (header `COLUMNS`; reasons joined by '; ')."""
    text = io.StringIO(newline="")
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(COLUMNS)
    writer.writerows(r.cells() for r in rows)
    return text.getvalue()


@dataclass(frozen=True)
class ClipToPlay:
    """What `replay DATASET --clip NAME` plays: the clip id, its source audio (a WAV written
    into a scratch folder; None when there is none) and the warnings to show first."""

    clip_id: str
    audio: Path | None
    warnings: tuple[str, ...]


def clip_to_play(
    dataset_dir: str | os.PathLike[str], name: str, *, scratch: Path, with_audio: bool
) -> ClipToPlay:
    """Resolve `name` (`resolve_clip`); with `with_audio`, cut the clip's source audio into
    `scratch`; warn about a clip the QC rejected and about audio that cannot be found."""
    from gesturebank import datasets

    if not Path(dataset_dir).is_dir():
        raise InputError(f"{dataset_dir}: --clip plays a clip of a dataset folder; this is none")
    data = datasets.open(dataset_dir)
    row = resolve_clip(data, name)
    warnings = []
    if row.status != "accepted":
        why = f": {'; '.join(row.reasons)}" if row.reasons else ""
        warnings.append(f"clip {row.clip_id} was {row.status} by the QC{why}; playing it anyway")
    audio = None
    if with_audio:
        rate = data.info.config.audio.sample_rate
        audio = write_clip_audio(data, row, out=scratch / f"{row.clip_id}.wav", sample_rate=rate)
        if audio is None:
            source = Path(data.info.videos_dir) / row.source
            warnings.append(f"{source}: no source audio found; playing without sound")
    return ClipToPlay(row.clip_id, audio, tuple(warnings))


def clip_timeline(dataset_dir: str | os.PathLike[str], clip_id: str) -> Timeline:
    """The smoothed, clamped 100 Hz angles of one dataset clip and their times (seconds from
    the clip's start), as `replay --clip` plays them; unknown angles (an unseen limb) held
    (`robot.timeline.hold`) and marked in `known`. The dataset's robot profile and reach mode
    come with them."""
    from gesturebank import datasets
    from gesturebank.robot.timeline import Timeline, reach_of

    data = datasets.open(dataset_dir)
    arrays = data.load_arrays(clip_id)
    return Timeline.of(
        arrays["times"],
        arrays["angles"],
        profile=data.info.robot_profile,
        reach=reach_of(data.info.config),
    )
