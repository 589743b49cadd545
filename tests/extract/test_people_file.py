"""`<video stem>.people.toml`: its two forms, each bad file a one-line error naming it, and the
person it names among tracked people; the main speaker is then that person."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturebank.config import TrackingConfig
from gesturebank.errors import InputError
from gesturebank.extract.people_file import chosen_track, read_people_file
from gesturebank.extract.tracking import main_speaker, track_ids
from tests.extract.test_tracking import SIZE, person, scene


def _write(tmp_path: Path, text: str) -> Path:
    video = tmp_path / "talk.mp4"
    (tmp_path / "talk.people.toml").write_text(text)
    return video


def test_no_file_is_none(tmp_path: Path) -> None:
    assert read_people_file(tmp_path / "talk.mp4") is None


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("person = ", "not a readable TOML file"),
        ("who = 1", "unknown key(s) who"),
        ("person = 1\nat = [0.5, 0.5]", "exactly one of"),
        ("person = -1", "person must be a track id"),
        ('person = "left"', "person must be a track id"),
        ("at = [0.5]", "at must be [x, y]"),
        ("at = [0.5, 1.5]", "at must be [x, y]"),
    ],
)
def test_bad_files_are_one_line_errors_naming_the_file(
    tmp_path: Path, text: str, problem: str
) -> None:
    video = _write(tmp_path, text)
    with pytest.raises(InputError) as exc:
        read_people_file(video)
    message = str(exc.value)
    assert message.startswith(str(tmp_path / "talk.people.toml") + ":")
    assert problem in message and "\n" not in message


def test_the_named_person_is_the_main_speaker(tmp_path: Path) -> None:
    # The big person in the middle would be chosen; the file names the small one on the left.
    multi = scene([[person(500, 450, height=400), person(150, 500, height=200)]] * 30)
    ids = track_ids(multi, TrackingConfig(), cuts=None)
    left = int(ids[0, int(np.argmin(multi.keypoints[0, :, 11, 0]))])
    by_point = read_people_file(_write(tmp_path, "at = [0.15, 0.6]"))
    assert by_point is not None and by_point.at == (0.15, 0.6)
    assert chosen_track(by_point, multi=multi, ids=ids) == left
    assert SIZE == multi.image_size
    tracked = main_speaker(multi, TrackingConfig(), ids=ids, keep=left)
    assert (tracked.report.main_ids == left).all()
    assert [c.reason for c in tracked.report.choices] == ["named"]
    by_id = read_people_file(_write(tmp_path, f"person = {left}"))
    assert by_id is not None and chosen_track(by_id, multi=multi, ids=ids) == left
    missing = read_people_file(_write(tmp_path, "person = 7"))
    assert missing is not None
    with pytest.raises(InputError, match=r"talk\.people\.toml: person 7 is not among"):
        chosen_track(missing, multi=multi, ids=ids)
