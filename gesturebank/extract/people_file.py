"""`<video stem>.people.toml` beside a video: the person to keep, for footage the main-speaker
choice gets wrong. Exactly one of:

    person = 2           # a track id, as the take record's tracking report names them
    at = [0.3, 0.55]     # the person nearest this point: x, y as shares of the image's width
                         # and height, from its top-left corner (their median upper-body centre)

That person is the main speaker wherever seen, in every shot (with build.people = "all" every
person is kept anyway; the file then changes nothing).
"""

from __future__ import annotations

import tomllib
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gesturebank.errors import InputError
from gesturebank.poses import MultiPose2D

SUFFIX = ".people.toml"


@dataclass(frozen=True)
class PeopleFile:
    """What a people file asks for: a track id, or a point of the image (shares)."""

    path: Path
    person: int | None = None
    at: tuple[float, float] | None = None


def people_file_of(video: Path) -> Path:
    return video.with_name(video.stem + SUFFIX)


def read_people_file(video: Path) -> PeopleFile | None:
    """The people file beside `video`, or None; InputError naming the file when it is bad."""
    path = people_file_of(Path(video))
    if not path.is_file():
        return None
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"{path}: not a readable TOML file ({exc})") from None
    unknown = set(data) - {"person", "at"}
    if unknown:
        raise InputError(f"{path}: unknown key(s) {', '.join(sorted(unknown))} (use person or at)")
    if len(data) != 1:
        raise InputError(f"{path}: give exactly one of person = <track id> or at = [x, y]")
    if "person" in data:
        person = data["person"]
        if not isinstance(person, int) or isinstance(person, bool) or person < 0:
            raise InputError(f"{path}: person must be a track id (an integer >= 0), got {person!r}")
        return PeopleFile(path, person=person)
    at = data["at"]
    ok = (
        isinstance(at, list)
        and len(at) == 2
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in at)
        and all(0 <= v <= 1 for v in at)
    )
    if not ok:
        raise InputError(f"{path}: at must be [x, y], shares of the image in [0, 1], got {at!r}")
    return PeopleFile(path, at=(float(at[0]), float(at[1])))


def chosen_track(spec: PeopleFile, *, multi: MultiPose2D, ids: np.ndarray) -> int:
    """The track id `spec` names among `ids (T, P)`; InputError naming the file when it names
    nobody there."""
    tracks = [int(k) for k in np.unique(ids[ids >= 0])]
    if spec.person is not None:
        if spec.person not in tracks:
            raise InputError(
                f"{spec.path}: person {spec.person} is not among the tracked people {tracks}"
            )
        return spec.person
    assert spec.at is not None
    if not tracks:
        raise InputError(f"{spec.path}: nobody is tracked in the video")
    w, h = multi.image_size
    point = np.array([spec.at[0] * w, spec.at[1] * h])
    xy = np.where(multi.keypoints[..., 2:3] > 0, multi.keypoints[..., :2], np.nan)
    with warnings.catch_warnings():  # empty slots: all-NaN slices are expected
        warnings.simplefilter("ignore", RuntimeWarning)
        centre = np.nanmean(xy, axis=-2)  # (T, P, 2)
        dist = {
            k: float(np.nanmedian(np.linalg.norm(centre[ids == k] - point, axis=-1)))
            for k in tracks
        }
    return min(tracks, key=lambda k: (np.nan_to_num(dist[k], nan=np.inf), k))
