"""Angle timeline CSV and dataset-take reading."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturebank.datasets.listing import clip_timeline
from gesturebank.errors import InputError
from gesturebank.robot.pepper import JOINTS
from gesturebank.robot.timeline import Timeline, read_timeline, write_timeline


def test_round_trip(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    times = np.arange(7) * 0.01 + 0.0125
    angles = rng.uniform(-1, 1, (7, 11)).astype(np.float32)
    back = read_timeline(write_timeline(tmp_path / "a.csv", Timeline.of(times, angles)))
    np.testing.assert_allclose(back.times, times, atol=1e-4)
    np.testing.assert_allclose(back.angles, angles, atol=1e-6)
    assert back.angles.dtype == np.float32 and back.angles.shape == (7, 11)


def test_columns_in_any_order_come_back_in_joint_order(tmp_path: Path) -> None:
    header = ["time_s", *reversed(JOINTS)]
    rows = ["0.0," + ",".join(str(k) for k in range(11, 0, -1)), "0.5," + ",".join(["0"] * 11)]
    path = tmp_path / "shuffled.csv"
    path.write_text(",".join(header) + "\n" + "\n".join(rows) + "\n")
    tl = read_timeline(path)
    # Reversed header + values 11..1 → HeadPitch (first joint, last column) holds 1.
    np.testing.assert_array_equal(tl.angles[0], np.arange(1, 12))
    assert tl.period == pytest.approx(0.5) and tl.end == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("time_s,HeadPitch\n0,0\n", "lacks column"),
        ("time_s," + ",".join(JOINTS) + "\n0," + ",".join(["x"] * 11) + "\n", "line 2"),
        (
            "time_s,"
            + ",".join(JOINTS)
            + "\n0.1,"
            + ",".join(["0"] * 11)
            + "\n0.1,"
            + ",".join(["0"] * 11)
            + "\n",
            "line 3: time_s must increase",
        ),
        ("time_s," + ",".join(JOINTS) + "\n0," + ",".join(["nan"] * 11) + "\n", "not a finite"),
        ("time_s," + ",".join(JOINTS) + "\n", "no frames"),
        ("", "empty file"),
    ],
)
def test_bad_csv_is_one_line_naming_the_file(tmp_path: Path, text: str, needle: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        read_timeline(path)
    msg = str(info.value)
    assert str(path) in msg and needle in msg and "\n" not in msg


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no such file"):
        read_timeline(tmp_path / "nope.csv")


def test_from_clip_reads_angles_and_holds_unknown_ones(tmp_path: Path) -> None:
    from gesturebank.robot import pepper
    from gesturebank.testing.clips import clip_from_targets, write_dataset

    profile = pepper.load_profile()
    angles01 = np.full((400, 11), 0.25)
    angles01[100:150, 4] = np.nan  # an unseen elbow: held at its last known value
    angles01[:50, 0] = np.nan  # unknown from the start: the first known value
    audio = np.zeros((400, 26))
    clip = clip_from_targets(angles01, audio, clip_id="s1_t__c000", profile=profile)
    write_dataset(tmp_path, {"s1_t": [clip]})
    tl = clip_timeline(tmp_path, "s1_t__c000")
    np.testing.assert_array_equal(tl.times, clip.times)
    assert np.isfinite(tl.angles).all()
    held = pepper.denormalise(np.full((400, 11), 0.25), profile)  # every value is this one
    np.testing.assert_allclose(tl.angles, held, atol=1e-6)


def test_from_clip_is_gone_from_the_robot_floor() -> None:
    """Issue 42: the deprecated `robot.timeline.from_clip` (a dataset read two floors up, by an
    import string the floor test could not see) is removed; `datasets.listing.clip_timeline`
    is the one name."""
    import gesturebank.robot.timeline as timeline

    assert not hasattr(timeline, "from_clip")
    assert "importlib" not in Path(timeline.__file__).read_text(encoding="utf-8")


def test_header_unit_and_reach(tmp_path: Path) -> None:
    from gesturebank.robot.timeline import read_timeline

    row = "0.5," + ",".join(["90"] * 11)
    path = tmp_path / "deg.csv"
    path.write_text("# robot profile: pepper-1.8; unit: deg; reach: soft\n"
                    f"time_s,{','.join(JOINTS)}\n{row}\n")  # fmt: skip
    tl = read_timeline(path)
    np.testing.assert_allclose(tl.angles, np.full((1, 11), np.pi / 2), atol=1e-6)
    assert (tl.profile, tl.reach) == ("pepper-1.8", "soft")
    path.write_text(f"time_s,{','.join(j + '_deg' for j in JOINTS)}\n{row}\n")
    np.testing.assert_allclose(read_timeline(path).angles, np.full((1, 11), np.pi / 2), atol=1e-6)
    for header, needle in (("# unit: grad", "angles in 'grad'"), ("# reach: far", "reach 'far'")):
        path.write_text(f"{header}\ntime_s,{','.join(JOINTS)}\n{row}\n")
        with pytest.raises(InputError, match=needle):
            read_timeline(path)
