"""Issue 33 item 1: every writer of an angle timeline through every reader, on real files.

Writers: `write_timeline`, `export --format csv` (of a dataset clip with masked angles),
`synthesize`, `replay`/`live` on the record backend (CSV and JSONL), and the two older dialects
(no comment line; `HeadPitch_rad` columns). Readers: `read_timeline`, `replay`, `export` (csv and
naoqi). Each writer says what the file must give back; each reader is checked against it.
"""

from __future__ import annotations

import json
import wave
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from gesturebank.cli.export import export_command
from gesturebank.cli.robot import live_command, replay_command
from gesturebank.config import Config, PlaybackConfig, TrainConfig
from gesturebank.datasets.listing import clip_timeline
from gesturebank.robot import pepper
from gesturebank.robot.backends.record import read_record
from gesturebank.robot.safety import safe_angles, speed_profile
from gesturebank.robot.timeline import (
    Timeline,
    reach_of,
    read_timeline,
    write_timeline,
)

FAST = PlaybackConfig(start_s=0.2, return_s=0.2)
N = 150


def _truth() -> Timeline:
    """1.5 s of slow motion inside the limits; the left arm unknown for 0.3 s and the hip roll
    never known (the left arm is still meanwhile, so holding it is exact)."""
    t = 0.0125 + np.arange(N) / 100
    neutral = pepper.neutral_pose().astype(np.float64)
    lo, hi = pepper.load_profile().lower, pepper.load_profile().upper
    a = lo + (hi - lo) * (0.5 + 0.1 * np.sin(2 * np.pi * 0.5 * t)[:, None])
    left = [pepper.JOINTS.index(j) for j in ("LShoulderPitch", "LShoulderRoll", "LElbowYaw")]
    a[:, left] = neutral[left]  # still
    a[40:70, left] = np.nan
    a[:, pepper.JOINTS.index("HipRoll")] = np.nan
    return Timeline.of(t, a, profile="pepper-1.7", reach="soft")


def _old_synthesize(path: Path, line: Timeline) -> Path:
    """What `synthesize` wrote before: a bare header, no comment, no empty cells."""
    rows = [",".join(["time_s", *pepper.JOINTS])]
    for t, a in zip(line.times, line.angles, strict=True):
        rows.append(f"{t:.4f}," + ",".join(f"{v:.6f}" for v in a))
    path.write_text("\n".join(rows) + "\n")
    return path


def _old_export(path: Path, line: Timeline) -> Path:
    """What `export --format csv` wrote before: a comment, `_rad` columns, empty unknown cells."""
    rows = [
        "# robot profile: pepper-1.7; angles in radians, NAOqi signs and zeros; time in seconds "
        "from the start",
        ",".join(["time_s", *(f"{j}_rad" for j in pepper.JOINTS)]),
    ]
    for t, a in zip(line.times, line.masked, strict=True):
        rows.append(f"{t:.4f}," + ",".join("" if np.isnan(v) else f"{v:.6f}" for v in a))
    path.write_text("\n".join(rows) + "\n")
    return path


def _played(line: Timeline) -> Timeline:
    """The frames replay sends for `line` (the player's safety applied)."""
    robot = speed_profile(pepper.load_profile(), FAST.max_speed_fraction)
    return Timeline.of(line.times, safe_angles(line, robot), profile=line.profile, reach=line.reach)


def _write_wav(path: Path, seconds: float, sr: int = 16000) -> Path:
    t = np.arange(int(seconds * sr)) / sr
    sound = 0.3 * np.sin(2 * np.pi * 220 * t) * (np.sin(2 * np.pi * 3 * t) > 0)
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(sr)
        w.writeframes((sound * 32767).astype("<i2").tobytes())
    return path


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A one-epoch MLP on a small generated dataset (a causal model: `live` runs it too)."""
    from gesturebank.cli.training import train_command
    from gesturebank.testing.speech_motion import write_speech_motion_dataset

    root = tmp_path_factory.mktemp("model")
    data = write_speech_motion_dataset(root / "ds", subjects=3, takes_per_subject=1, seconds=4.0)
    one = TrainConfig.model_validate({"mlp": {"max_epochs": 1}})
    train_command(
        data,
        model="mlp",
        variant="si",
        fold=0,
        subject=None,
        out_dir=root / "mlp",
        config=one,
        quiet=True,
    )
    return root / "mlp"


def _from_dataset(folder: Path) -> tuple[Path, Timeline]:
    from gesturebank.testing.clips import clip_from_targets, write_dataset

    angles01 = np.full((N, 11), 0.5)
    angles01[:, 4] = np.linspace(0.3, 0.7, N)
    angles01[30:60, 7] = np.nan  # an unseen right arm joint
    clip = clip_from_targets(
        angles01, np.zeros((N, 26)), clip_id="s1_t__c000", profile=pepper.load_profile()
    )
    write_dataset(folder / "ds", {"s1_t": [clip]})
    config = Config()
    out = export_command(src=folder / "ds", fmt="csv", out=folder / "csv", config=config)
    return out[0], clip_timeline(folder / "ds", "s1_t__c000")


def _synthesized(folder: Path, model: Path) -> tuple[Path, Timeline]:
    from gesturebank.train.synthesis import synthesize

    wav = _write_wav(folder / "speech.wav", 1.0)
    angles = synthesize(model, audio_path=wav, out_csv=folder / "synth.csv")
    audio = json.loads((model / "model.json").read_text())["audio"]
    times = np.arange(len(angles)) * audio["winstep_s"] + audio["winlen_s"] / 2
    reach = json.loads((model / "model.json").read_text())["reach"]  # its dataset's mode
    return folder / "synth.csv", Timeline.of(times, angles, profile="pepper-1.7", reach=reach)


def _replayed(folder: Path, suffix: str, mode: str = "stream") -> tuple[Path, Timeline]:
    truth = _truth()
    src = write_timeline(folder / "src.csv", truth)
    config = FAST.model_copy(update={"mode": mode})  # interpolate: one angleInterpolation call
    replay_command(src, backend="record", out=folder / f"played{suffix}", config=config)
    played = _played(truth)
    if mode == "interpolate":  # the robot holds frame 0 (the start move's end) when called
        played = Timeline.of(
            played.times[1:], played.angles[1:], profile="pepper-1.7", reach="soft"
        )
    return folder / f"played{suffix}", played


def _live(folder: Path, model: Path, csv: bool) -> tuple[Path, Timeline]:
    """Live on the same speech twice: the JSONL's calls (read as JSON) are what both must give
    (the angles: the times are when each chunk arrived)."""
    wav = _write_wav(folder / "speech.wav", 0.5)
    jsonl = folder / "live.jsonl"
    live_command(model, backend="record", input=str(wav), out=jsonl, config=FAST)
    calls = [c for c in read_record(jsonl) if c["phase"] == "live"]
    reach = json.loads((model / "model.json").read_text())["reach"]  # its dataset's mode
    expected = Timeline.of(
        [c["t"] for c in calls], [c["angles"] for c in calls], profile="pepper-1.7", reach=reach
    )
    if not csv:
        return jsonl, expected
    out = folder / "live.csv"
    live_command(model, backend="record", input=str(wav), out=out, config=FAST, csv=True)
    return out, expected


WRITERS: dict[str, Callable[[Path, Path], tuple[Path, Timeline]]] = {
    "write_timeline": lambda d, m: (write_timeline(d / "a.csv", _truth()), _truth()),
    "export-csv": lambda d, m: _from_dataset(d),
    "synthesize": _synthesized,
    "replay-record-csv": lambda d, m: _replayed(d, ".csv"),
    "replay-record-jsonl": lambda d, m: _replayed(d, ".jsonl"),
    "replay-interpolate-csv": lambda d, m: _replayed(d, ".csv", "interpolate"),
    "replay-interpolate-jsonl": lambda d, m: _replayed(d, ".jsonl", "interpolate"),
    "live-jsonl": lambda d, m: _live(d, m, csv=False),
    "live-csv": lambda d, m: _live(d, m, csv=True),
    "old-synthesize": lambda d, m: (_old_synthesize(d / "old.csv", _truth()), _held(_truth())),
    "old-export": lambda d, m: (_old_export(d / "old.angles.csv", _truth()), _unnamed(_truth())),
}


def _held(line: Timeline) -> Timeline:
    """`line` with nothing unknown (a format with no empty cells carries the held values) and
    no profile or reach named."""
    return Timeline.of(line.times, line.angles)


def _unnamed(line: Timeline) -> Timeline:
    """`line` naming no reach (the old export's comment line named only the profile)."""
    return Timeline.of(line.times, line.masked, profile=line.profile)


@pytest.fixture(scope="module")
def written(
    model: Path, tmp_path_factory: pytest.TempPathFactory
) -> dict[str, tuple[Path, Timeline]]:
    root = tmp_path_factory.mktemp("writers")
    out = {}
    for name in WRITERS:
        folder = root / name
        folder.mkdir()
        out[name] = WRITERS[name](folder, model)
    return out


def _same(got: Timeline, want: Timeline, *, mask: bool = True, angles_only: bool = False) -> None:
    if not angles_only:
        np.testing.assert_allclose(got.times, want.times, atol=1e-4)
    np.testing.assert_allclose(got.angles, want.angles, atol=2e-6)
    if mask:
        want_known = np.ones(want.angles.shape, bool) if want.known is None else want.known
        got_known = np.ones(got.angles.shape, bool) if got.known is None else got.known
        np.testing.assert_array_equal(got_known, want_known)


@pytest.mark.parametrize("writer", list(WRITERS))
def test_read_timeline(written: dict[str, tuple[Path, Timeline]], writer: str) -> None:
    path, want = written[writer]
    got = read_timeline(path)
    _same(got, want, angles_only=writer == "live-csv")
    if writer in ("write_timeline", "synthesize", "export-csv", "live-csv", "replay-record-csv"):
        assert path.read_text().startswith("# gesturebank angle timeline; robot profile: pepper-")
        assert got.profile == "pepper-1.7" and got.reach in ("clamp", "soft")
    if writer in ("write_timeline", "old-export"):  # masked cells: empty in the file, held here
        assert got.known is not None and not got.known[:, pepper.JOINTS.index("HipRoll")].any()
        assert np.isfinite(got.angles).all()


@pytest.mark.parametrize("writer", list(WRITERS))
def test_replay_plays_it(
    written: dict[str, tuple[Path, Timeline]], writer: str, tmp_path: Path
) -> None:
    path, want = written[writer]
    replay_command(path, backend="record", out=tmp_path / "out.csv", config=FAST)
    got = read_timeline(tmp_path / "out.csv")
    _same(got, _played(_held(want)), mask=False, angles_only=writer == "live-csv")
    assert got.known is None  # what a robot was sent is always known


@pytest.mark.parametrize("writer", list(WRITERS))
def test_export_reads_it(
    written: dict[str, tuple[Path, Timeline]], writer: str, tmp_path: Path
) -> None:
    path, want = written[writer]
    (csv,) = export_command(src=path, fmt="csv", out=tmp_path / "again.csv", config=Config())
    again = read_timeline(csv)
    _same(again, want, angles_only=writer == "live-csv")  # masked cells stay masked
    assert again.reach == (want.reach or reach_of(Config()))  # the file's, else the config's
    (js, _) = export_command(src=path, fmt="naoqi", out=tmp_path / "a.naoqi.json", config=Config())
    sent = np.array(json.loads(js.read_text())["angleLists"]).T
    np.testing.assert_allclose(sent, _played(_held(want)).angles, atol=2e-6)


def test_live_csv_is_the_record_backend_s(model: Path, tmp_path: Path) -> None:
    from gesturebank.errors import InputError

    wav = _write_wav(tmp_path / "s.wav", 0.2)
    with pytest.raises(InputError, match="--csv writes the record backend's file"):
        live_command(
            model, backend="sim", input=str(wav), out=tmp_path / "x.mp4", config=FAST, csv=True
        )


def test_stimuli_shows_it(
    written: dict[str, tuple[Path, Timeline]], model: Path, tmp_path: Path
) -> None:
    """Issue 44 item 10: every writer's file, given to `stimuli --timelines` as another
    system's motion of one speech, is what that condition's video shows: the angles it records
    beside the video (`motion/<id>.csv`) are the file's, held and made safe as replay plays
    them, cut to the speech's duration."""
    import shutil

    from gesturebank.config import RenderConfig
    from gesturebank.study.stimuli import KEY, stimuli_command

    wav = _write_wav(tmp_path / "speech.wav", 1.2)
    folders = []
    for writer, (path, _) in written.items():
        folder = tmp_path / "systems" / writer
        folder.mkdir(parents=True)
        shutil.copy(path, folder / f"speech{'.jsonl' if path.suffix == '.jsonl' else '.csv'}")
        folders.append(folder)
    out = tmp_path / "study"
    small = RenderConfig(frame_rate=5, width_px=96, height_px=64)
    stimuli_command(model_dirs=[model], out=out, audios=[wav], timelines=folders, render=small)
    key = json.loads((out / KEY).read_text())["videos"]
    shown = {v["condition"]: vid for vid, v in key.items()}
    assert set(written) <= set(shown)
    differ = {}
    for writer, (_, want) in written.items():
        assert key[shown[writer]]["timelines"] == str(tmp_path / "systems" / writer)
        assert (out / "videos" / f"{shown[writer]}.mp4").is_file()
        got = read_timeline(out / "motion" / f"{shown[writer]}.csv")
        keep = max(1, int(np.searchsorted(want.times, 1.2, side="left")))
        cut = Timeline.of(want.times[:keep], _held(want).angles[:keep])
        try:
            _same(got, _played(cut), mask=False, angles_only=writer == "live-csv")
        except AssertionError as exc:
            differ[writer] = str(exc).splitlines()[-1]
    assert not differ, differ


def test_stimuli_names_a_missing_or_foreign_timeline(
    written: dict[str, tuple[Path, Timeline]], model: Path, tmp_path: Path
) -> None:
    from gesturebank.errors import InputError
    from gesturebank.study.stimuli import stimuli_command

    wav = _write_wav(tmp_path / "talk.wav", 0.2)
    (tmp_path / "sys").mkdir()
    with pytest.raises(InputError, match=r"sys/talk\.csv: no timeline for speech talk"):
        stimuli_command(
            model_dirs=[model], out=tmp_path / "a", audios=[wav], timelines=[tmp_path / "sys"]
        )
    text = written["write_timeline"][0].read_text().replace("pepper-1.7", "pepper-1.8", 1)
    (tmp_path / "sys" / "talk.csv").write_text(text)
    with pytest.raises(InputError, match=r"talk\.csv: angles for robot profile pepper-1\.8"):
        stimuli_command(
            model_dirs=[model], out=tmp_path / "b", audios=[wav], timelines=[tmp_path / "sys"]
        )
