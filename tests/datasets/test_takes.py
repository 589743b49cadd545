import logging
import re
import unicodedata
from pathlib import Path

import pytest

from gesturebank.config import BuildConfig
from gesturebank.datasets.takes import discover_takes, take_id
from gesturebank.errors import ConfigError, InputError


def touch(root: Path, *names: str) -> None:
    for n in names:
        (root / n).parent.mkdir(parents=True, exist_ok=True)
        (root / n).write_bytes(b"")


def test_ids_subjects_from_folders_and_sidecar_wav(tmp_path: Path) -> None:
    touch(tmp_path, "anna/talk 1.mp4", "anna/talk 1.wav", "bob/x.MOV", "notes.txt", ".hidden/y.mp4")
    takes = discover_takes(tmp_path)
    assert [(t.take_id, t.subject) for t in takes] == [("anna__talk_1", "anna"), ("bob__x", "bob")]
    assert takes[0].audio == tmp_path / "anna/talk 1.wav"
    assert takes[1].audio is None


def test_subjects_csv_wins_then_pattern(tmp_path: Path) -> None:
    touch(tmp_path, "day1/p07_story.mp4", "day1/p08_story.mp4")
    cfg = BuildConfig(subject_pattern=r"(?P<subject>p\d+)_")
    assert [t.subject for t in discover_takes(tmp_path, cfg)] == ["p07", "p08"]
    (tmp_path / "subjects.csv").write_text("take,subject,extraversion\np07_story,alice,4.5\n")
    takes = discover_takes(tmp_path, cfg)
    assert [t.subject for t in takes] == ["alice", "p08"]
    assert takes[0].traits == {"extraversion": "4.5"}


def test_bad_inputs(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not a directory"):
        discover_takes(tmp_path / "missing")
    touch(tmp_path, "a/x.mp4")
    with pytest.raises(ConfigError, match="subject_pattern"):
        discover_takes(tmp_path, BuildConfig(subject_pattern="(unclosed"))
    (tmp_path / "subjects.csv").write_text("video,who\n")
    with pytest.raises(InputError, match="subjects.csv: needs the columns"):
        discover_takes(tmp_path)


def test_colliding_ids_are_an_error(tmp_path: Path) -> None:
    assert take_id(Path("a b/c.mp4")) == take_id(Path("a_b/c.mp4"))
    touch(tmp_path, "a b/c.mp4", "a_b/c.mp4")
    with pytest.raises(InputError, match="same take id"):
        discover_takes(tmp_path)


def test_ids_transliterate_accents_and_keep_other_scripts(tmp_path: Path) -> None:
    assert take_id(Path("ünï cödé/x.mp4")) == "uni_code__x"  # was '_n_c_d___x'
    assert take_id(Path(unicodedata.normalize("NFD", "ünï cödé/x.mp4"))) == "uni_code__x"
    assert take_id(Path("Ｆｕｌｌ ﬁle.mp4")) == "Full_file"
    # ASCII names keep the ids they always had (existing datasets stay valid)
    ascii_name = "".join(chr(c) for c in range(32, 127) if chr(c) not in "/\\")
    expected = re.sub(r"[^A-Za-z0-9._-]+", "_", ascii_name)
    assert take_id(Path(ascii_name), folder=True) == expected
    # other scripts stay readable, distinct and non-empty (が and か differ by a mark only)
    names = ["日本/がか.mp4", "日本/かか.mp4", "Привет мир.mp4", "Привет миp.mp4", "हिन्दी.mp4"]
    touch(tmp_path, *names)
    ids = [t.take_id for t in discover_takes(tmp_path)]
    assert len(set(ids)) == len(names) and all(i.strip("_") for i in ids)
    assert "Привет_мир" in ids and "日本__がか" in ids
    touch(tmp_path, "ü.mp4", "u.mp4")  # transliterated alike: refused, never merged
    with pytest.raises(InputError, match="same take id 'u'"):
        discover_takes(tmp_path)


def test_output_folder_inside_videos_dir_is_not_searched(tmp_path: Path) -> None:
    touch(tmp_path, "anna/a.mp4", "out/qc/render.mp4", "out/takes/x.mp4")
    assert [t.take_id for t in discover_takes(tmp_path, out_dir=tmp_path / "out")] == ["anna__a"]
    assert len(discover_takes(tmp_path, out_dir=tmp_path / "elsewhere")) == 3
    # OUT_DIR = VIDEOS_DIR: the videos are still found
    assert len(discover_takes(tmp_path / "anna", out_dir=tmp_path / "anna")) == 1


def warnings(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]


def test_subjects_csv_mistakes_are_warned_with_file_and_row(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    touch(tmp_path, "day1/p07_story.mp4", "day1/p08_story.mp4", "day1/p09_story.mp4")
    csv_path = tmp_path / "subjects.csv"
    csv_path.write_text("take,subject\np07_story,alice\np08_story,bob\np09_story,carol\n")
    with caplog.at_level(logging.WARNING):
        takes = discover_takes(tmp_path)
    assert warnings(caplog) == []  # a correct file is quiet
    assert [t.subject for t in takes] == ["alice", "bob", "carol"]
    caplog.clear()
    csv_path.write_text(
        "take,subject\n"
        "p07_story,alice\n"  # row 2
        "p08_stroy,bob\n"  # row 3: a typo
        "p07_story,dave\n"  # row 4: the same take again
        "ghost,eve\n"  # row 5: no such take
        ",frank\n"  # row 6: no take name
        "day1/p07_story.mp4,gina,extra\n"  # row 7: another name of p07, one cell too many
    )
    with caplog.at_level(logging.WARNING):
        takes = discover_takes(tmp_path)
    text = warnings(caplog)
    assert all(str(csv_path) in w for w in text), text

    def said(*words: str) -> bool:
        return any(all(w in line for w in words) for line in text)

    assert said("row 3", "'p08_stroy'", "did you mean 'p08_story'?")
    assert said("row 4", "also on row 2")
    assert said("row 5", "'ghost'") and not said("row 5", "did you mean")
    assert said("row 6", "no take name")
    assert said("row 7", "more cells than columns")
    assert said("rows 7 and 4", "same take day1__p07_story", "row 7 is used")  # a path wins
    assert said("no row for 2 take(s)", "day1__p08_story", "day1__p09_story")
    assert [t.subject for t in takes] == ["gina", "day1", "day1"]


def test_a_row_naming_several_takes_is_warned(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    touch(tmp_path, "a/story.mp4", "b/story.mp4")
    (tmp_path / "subjects.csv").write_text("take,subject\nstory,alice\n")
    with caplog.at_level(logging.WARNING):
        discover_takes(tmp_path)
    assert any("row 2: 'story' names 2 takes (a__story, b__story)" in w for w in warnings(caplog))


def test_video_files_as_input(tmp_path: Path) -> None:
    """Issue 33 item 7: one video file, or several, instead of a folder."""
    from gesturebank.datasets.takes import find_inputs

    touch(tmp_path, "anna/talk.mp4", "anna/talk.wav", "bob/x.mp4", "bob/y.mp4", "notes.txt")
    cfg = BuildConfig()
    root, takes = find_inputs([tmp_path / "anna/talk.mp4"], cfg)
    assert root == (tmp_path / "anna").resolve()
    assert [(t.take_id, t.subject) for t in takes] == [("talk", "anna")]
    assert takes[0].audio == (tmp_path / "anna/talk.wav").resolve()
    root, takes = find_inputs([tmp_path / "bob/y.mp4", tmp_path / "anna/talk.mp4"], cfg)
    assert root == tmp_path.resolve()  # only the files given, not bob/x.mp4
    assert [(t.take_id, t.subject) for t in takes] == [("anna__talk", "anna"), ("bob__y", "bob")]
    root, takes = find_inputs([tmp_path], cfg)  # a folder: as before
    assert root == tmp_path and len(takes) == 3
    for bad, message in (
        ([tmp_path / "notes.txt"], "notes.txt: not a video"),
        ([tmp_path / "nope.mp4"], "nope.mp4: no such file or folder"),
        ([tmp_path / "bob/x.mp4", tmp_path / "anna"], "anna: a folder among files"),
    ):
        with pytest.raises(InputError, match=re.escape(message)):
            find_inputs(bad, cfg)


def test_a_flat_folder_names_its_subject_as_a_single_file_does(tmp_path: Path) -> None:
    """Issue 44: videos right in VIDEOS_DIR got subject 'unknown'; one of them given alone got
    the folder's name. Both now take the folder's name."""
    from gesturebank.datasets.takes import find_inputs

    talks = tmp_path / "talks"
    touch(talks, "a.mp4", "b.mp4")
    assert [t.subject for t in discover_takes(talks)] == ["talks", "talks"]
    _, alone = find_inputs([talks / "a.mp4"], BuildConfig())
    assert [t.subject for t in alone] == ["talks"]


def test_too_few_subjects_names_them_and_how_to_set_them() -> None:
    from gesturebank.config import SplitsConfig
    from gesturebank.datasets.splits import subject_independent

    rows = [
        {"clip_id": f"c{i}", "take_id": f"t{i}", "subject": s, "qc_status": "accepted",
         "n_frames": 100, "start_s": 0.0}
        for i, s in enumerate(["talks", "talks"])
    ]  # fmt: skip
    with pytest.raises(InputError) as err:
        subject_independent(rows, config=SplitsConfig())
    message = str(err.value)
    assert "the dataset has 1 (talks)" in message
    assert "subjects.csv" in message and "build.subject_pattern" in message
