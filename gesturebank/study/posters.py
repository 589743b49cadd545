"""Poster frames: one still of each stimulus video, shown before it is played (`<video poster>`),
so that a page of videos is not a row of black boxes. A frame from the middle of the video
(the first is the robot's start pose, the same in every condition)."""

from __future__ import annotations

import os
from pathlib import Path

from gesturebank.errors import InputError
from gesturebank.fileio import write_bytes_atomic

POSTERS = "posters"  # the study folder's sub-folder: posters/<video id>.jpg


def poster_path(folder: Path, stimulus: str) -> Path:
    return folder / POSTERS / f"{stimulus}.jpg"


def write_poster(video: Path, out: Path) -> Path:
    """The frame at the middle of `video` as a JPEG at `out` (PyAV decodes it)."""
    import io

    import av

    try:
        with av.open(os.fspath(video)) as container:
            stream = container.streams.video[0]
            frames = stream.frames or 0
            middle = frames // 2
            chosen = None
            for k, frame in enumerate(container.decode(stream)):
                chosen = frame
                if k >= middle:
                    break
    except (av.error.FFmpegError, IndexError) as exc:
        raise InputError(f"{video}: no video frame for a poster ({exc})") from None
    if chosen is None:
        raise InputError(f"{video}: no video frame for a poster")
    buffer = io.BytesIO()
    chosen.to_image().save(buffer, format="JPEG", quality=85)
    write_bytes_atomic(out, buffer.getvalue())
    return out


def ensure_posters(folder: Path, files: dict[str, str]) -> None:
    """A poster for every stimulus (`id → video file` relative to `folder`) that has none yet."""
    for stimulus, file in files.items():
        out = poster_path(folder, stimulus)
        if not out.is_file():
            out.parent.mkdir(parents=True, exist_ok=True)
            write_poster(folder / file, out)
