"""The installed console scripts: help texts, exit codes, one-line errors."""

import os
import subprocess
import sys
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

BIN = Path(sys.executable).parent


def run(*args: str, columns: int | None = None) -> subprocess.CompletedProcess[str]:
    cmd = [str(BIN / args[0]), *args[1:]]
    env = None if columns is None else {**os.environ, "COLUMNS": str(columns)}
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False, env=env)


def run_each(
    cases: Sequence[Sequence[str]], *, columns: int | None = None
) -> list[subprocess.CompletedProcess[str]]:
    """`run` of each command, two at a time (independent commands; each one's start, mostly
    imports, keeps one core busy), in the order given."""
    with ThreadPoolExecutor(max_workers=min(2, os.cpu_count() or 1)) as pool:
        return list(pool.map(lambda args: run(*args, columns=columns), cases))


def fits(text: str, columns: int = 80) -> bool:
    """Every line within `columns` and none cut short by rich (`…`)."""
    return all(len(ln.rstrip()) <= columns and "…" not in ln for ln in text.splitlines())


def test_help_lists_every_command_with_text() -> None:
    r = run("gesturebank", "--help")
    assert r.returncode == 0
    for command, words in {
        "info": "detectors and lifters",
        "fetch-samples": "sample media",
        "config": "resolved configuration",
        "build-dataset": "Pepper angles",
    }.items():
        line = next(ln for ln in r.stdout.splitlines() if f" {command} " in ln)
        assert words in line, line


COMMANDS = [
    "info",
    "fetch-samples",
    "config",
    "build-dataset",
    "qc",
    "train",
    "evaluate",
    "synthesize",
    "replay",
    "preview",
    "clips",
    "render",
    "live",
    "calibrate",
    "export",
]


@pytest.fixture(scope="module")
def helps() -> dict[str, subprocess.CompletedProcess[str]]:
    """`gesturebank COMMAND --help` of every command, run two at a time."""
    done = run_each([("gesturebank", command, "--help") for command in COMMANDS])
    return dict(zip(COMMANDS, done, strict=True))


@pytest.mark.parametrize("command", COMMANDS)
def test_each_command_has_help(
    command: str, helps: dict[str, subprocess.CompletedProcess[str]]
) -> None:
    r = helps[command]
    assert r.returncode == 0
    assert "Usage: gesturebank " + command in r.stdout


def test_build_dataset_script_is_the_same_command() -> None:
    a = run("build-dataset", "--help").stdout.splitlines()
    b = run("gesturebank", "build-dataset", "--help").stdout.splitlines()
    usage_a = next(ln for ln in a if "Usage:" in ln)
    usage_b = next(ln for ln in b if "Usage:" in ln)
    assert usage_a.strip().replace("build-dataset", "gesturebank build-dataset") == usage_b.strip()
    # everything after the usage line (description, arguments, options) is identical
    assert a[a.index(usage_a) + 1 :] == b[b.index(usage_b) + 1 :]


def test_info_lists_registries() -> None:
    r = run("gesturebank", "info")
    assert r.returncode == 0
    assert "detectors" in r.stdout
    assert "lifters" in r.stdout
    assert "mediapipe" in r.stdout


def test_usage_errors_exit_2_with_one_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[detector]\nnmae = 'mediapipe'\n")
    videos = tmp_path / "videos"
    videos.mkdir()
    (videos / "notes.txt").write_text("no video here")
    blocker = tmp_path / "file"
    blocker.write_text("x")
    cases = [
        (("config", "--config", str(bad)), "detector: nmae: unknown key (did you mean name?)"),
        (("build-dataset", str(tmp_path / "nope"), str(tmp_path / "o")), "no such file or folder"),
        (("build-dataset", str(videos), str(tmp_path / "o")), "no videos found"),
        (("build-dataset", str(videos), str(tmp_path / "o"), "--set", "audio.nfilt=0"), "nfilt"),
        (("config", "--set", "qc.outlier_z=-1"), "qc.outlier_z"),
    ]
    done = run_each([("gesturebank", *args) for args, _ in cases])
    for (args, message), r in zip(cases, done, strict=True):
        assert r.returncode == 2, (args, r.stderr)
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1, r.stderr
        assert message in lines[0]
    (videos / "a.mp4").write_bytes(b"")
    r = run("build-dataset", str(videos), str(blocker / "out"))
    assert r.returncode == 2
    assert "cannot create output folder" in r.stderr
    assert run("gesturebank", "no-such-command").returncode == 2


def test_config_prints_resolved_toml(tmp_path: Path) -> None:
    import tomllib

    cfg = tmp_path / "c.toml"
    cfg.write_text("[audio]\nnfilt = 40\n")
    r = run("gesturebank", "config", "--config", str(cfg), "--set", "processing.cutoff_hz=6")
    assert r.returncode == 0
    data = tomllib.loads(r.stdout)
    assert data["audio"]["nfilt"] == 40
    assert data["processing"]["cutoff_hz"] == 6
    assert data["processing"]["butter_order"] == 5


def test_an_old_config_key_is_shown_as_deprecated(tmp_path: Path) -> None:
    """Python hides a DeprecationWarning not raised by __main__: the command shows it."""
    cfg = tmp_path / "old.toml"
    cfg.write_text('[geometric]\nunits = "m"\n')
    r = run("gesturebank", "config", "--config", str(cfg))
    assert r.returncode == 0, r.stderr
    assert "config key [geometric] is deprecated: use [lifter.geometric]" in r.stderr
    assert 'units = "m"' in r.stdout


def test_train_and_qc_output_errors_are_one_line(demo_dataset: Path, tmp_path: Path) -> None:
    """Too few subjects for SI (the demo has 2), unwritable --out or qc/: one line, exit 2."""
    import shutil

    blocker = tmp_path / "file"  # a path under a regular file fails for root too (ENOTDIR)
    blocker.write_text("x")
    dataset = tmp_path / "ds"
    shutil.copytree(demo_dataset, dataset)
    shutil.rmtree(dataset / "qc")
    (dataset / "qc").write_text("not a folder")
    sd = ["--variant", "sd", "--subject", "lab"]
    cases = [
        (("train", str(dataset), "-q"), "2 subjects, too few for --variant si (needs 3); train"),
        (("train", str(dataset), *sd, "--out", str(blocker / "m")), "cannot write the model"),
        (("qc", str(dataset)), f"{dataset}: cannot write the QC results"),
    ]
    done = run_each([("gesturebank", *args) for args, _ in cases])
    for (args, message), r in zip(cases, done, strict=True):
        assert r.returncode == 2, (args, r.stderr)
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and message in lines[0], r.stderr


def test_train_synthesize_replay_live_chain(demo_dataset: Path, samples: Path, tmp_path) -> None:
    """The robot-side commands chained as a user would, through the installed script."""
    import json

    model = tmp_path / "model"
    wav = samples / "speech" / "arctic_a0009.wav"
    fast = ["--set", "train.lstm.max_epochs=2"]
    r = run("gesturebank", "train", str(demo_dataset), "--model", "lstm", "--variant", "sd",
            "--subject", "lab", "--out", str(model), "-q", *fast)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert (model / "model_step.onnx").is_file()
    r = run("gesturebank", "evaluate", str(model), columns=80)
    assert r.returncode == 0, r.stderr
    assert "mean pose" in r.stdout and "RMSE" in r.stdout
    # issue 44: at 80 columns headers were cut (`Subje…`, `avera…`); short ones and their units
    assert fits(r.stdout), r.stdout
    assert " Subject " in r.stdout and " average " in r.stdout and "units: RMSE °" in r.stdout
    # the 1.06 s test part is shorter than the 3 s LCCA window: flagged, not scored, no warnings
    assert "LCCA, CCA, FCCA not computable" in r.stdout and "Warning" not in r.stderr
    csv = tmp_path / "angles.csv"
    r = run("gesturebank", "synthesize", str(model), str(wav), "--out", str(csv), "--znorm", "lab")
    assert r.returncode == 0, r.stderr
    comment, head = csv.read_text().splitlines()[:2]
    assert comment.startswith("# gesturebank angle timeline; robot profile: pepper-")
    assert head.split(",")[:2] == ["time_s", "HeadPitch"] and len(head.split(",")) == 12
    # issue 33: what export writes, replay and export read back (no `_rad` dialect of their own)
    exported = tmp_path / "angles.angles.csv"
    r = run("gesturebank", "export", str(csv), "--format", "csv", "--out", str(exported))
    assert r.returncode == 0, r.stderr
    r = run("gesturebank", "replay", str(exported), "--backend", "record",
            "--out", str(tmp_path / "x.csv"))  # fmt: skip
    assert r.returncode == 0, r.stderr
    sent = tmp_path / "sent.jsonl"
    r = run("gesturebank", "replay", str(csv), "--backend", "record", "--out", str(sent))
    assert r.returncode == 0, r.stderr
    assert len(sent.read_text().splitlines()) > len(csv.read_text().splitlines())  # + start/return
    live = tmp_path / "live.jsonl"
    r = run("gesturebank", "live", str(model), "--backend", "record", "--input", str(wav),
            "--out", str(live), "--znorm", "lab")  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "0 skipped" in r.stdout
    first = json.loads(live.read_text().splitlines()[0])
    assert first  # a real command was recorded
    live_csv = tmp_path / "live.csv"  # live --csv: the poses sent, as an angle timeline
    r = run("gesturebank", "live", str(model), "--backend", "record", "--input", str(wav),
            "--out", str(live_csv), "--csv", "--znorm", "lab")  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert live_csv.read_text().startswith("# gesturebank angle timeline; robot profile: pepper-")
    for recorded in (live, sent, live_csv):  # a record file replays and exports as a timeline
        r = run("gesturebank", "replay", str(recorded), "--backend", "record",
                "--out", str(tmp_path / "again.jsonl"), "--force")  # fmt: skip
        assert r.returncode == 0, r.stderr
        r = run("gesturebank", "export", str(recorded), "--format", "naoqi",
                "--out", str(tmp_path / "r.naoqi.json"), "--force")  # fmt: skip
        assert r.returncode == 0, r.stderr
    r = run("gesturebank", "replay", str(csv), "--backend", "naoqi", "--url", "tcp://127.0.0.1:1")
    assert r.returncode == 1  # the robot failed: one line, no traceback
    assert len([ln for ln in r.stderr.splitlines() if ln.strip()]) == 1


def test_every_writer_keeps_an_existing_output_unless_forced(tmp_path: Path) -> None:
    """Issue 44: a second `train` wiped a trained model without a word. Every command that
    writes an output keeps an existing one, exits 2 and names --force."""
    model = tmp_path / "model"
    model.mkdir()
    (model / "model.json").write_text("{}")
    kept = tmp_path / "kept.csv"
    kept.write_text("precious")
    study = tmp_path / "study"
    study.mkdir()
    (study / "key.json").write_text("{}")
    dataset, wav = str(tmp_path / "ds"), str(tmp_path / "a.wav")
    timeline = tmp_path / "t.csv"
    joints = "HeadPitch,HeadYaw,LShoulderPitch,LShoulderRoll,LElbowYaw,LElbowRoll,"
    joints += "RShoulderPitch,RShoulderRoll,RElbowYaw,RElbowRoll,HipRoll"
    timeline.write_text(f"time_s,{joints}\n" + "".join(f"{t}{',0' * 11}\n" for t in (0, 0.01)))
    cases = [
        ("train", dataset, "--variant", "sd", "--subject", "lab", "--out", str(model)),
        ("synthesize", str(model), wav, "--out", str(kept)),
        ("export", str(tmp_path / "t.csv"), "--format", "csv", "--out", str(kept)),
        ("stimuli", str(model), "--audio", wav, "--out", str(study)),
        ("preview", dataset, "--clip", "c", "--out", str(kept)),
        ("replay", str(tmp_path / "t.csv"), "--backend", "record", "--out", str(kept)),
        ("live", str(model), "--backend", "record", "--input", wav, "--out", str(kept)),
    ]
    for args, r in zip(cases, run_each([("gesturebank", *a) for a in cases]), strict=True):
        assert r.returncode == 2, (args, r.stdout, r.stderr)
        assert "already exists and is kept; --force replaces it" in r.stderr, (args, r.stderr)
    assert kept.read_text() == "precious" and (model / "model.json").read_text() == "{}"
    assert (study / "key.json").is_file()
    # with --force the output is replaced
    forced = ("export", str(timeline), "--format", "csv", "--out", str(kept), "--force")
    r = run("gesturebank", *forced)
    assert r.returncode == 0, r.stderr
    assert kept.read_text() != "precious"


def test_every_name_choice_says_the_flag_the_values_and_the_closest(tmp_path: Path) -> None:
    """Issue 44: `--model lsmt` had no "did you mean lstm", as config keys do. Every name
    choice now names its flag, lists the valid values and suggests the closest."""
    timeline = tmp_path / "t.csv"
    joints = "HeadPitch,HeadYaw,LShoulderPitch,LShoulderRoll,LElbowYaw,LElbowRoll,"
    joints += "RShoulderPitch,RShoulderRoll,RElbowYaw,RElbowRoll,HipRoll"
    timeline.write_text(f"time_s,{joints}\n" + "".join(f"{t}{',0' * 11}\n" for t in (0, 0.01)))
    videos = tmp_path / "videos"
    videos.mkdir()
    (videos / "a.mp4").write_bytes(b"")
    out, ds = str(tmp_path / "out"), str(tmp_path / "ds")
    cases = [
        (("train", ds, "--model", "lsmt"), "--model", "lstm", "aud2motion, "),
        (("train", ds, "--variant", "dyadc"), "--variant", "dyadic", "si, sd, dyadic"),
        (("train", ds, "--target", "listner"), "--target", "listener", "speaker, listener"),
        (("evaluate", ds, "--split", "tset"), "--split", "test", "test, val, train"),
        (("export", str(timeline), "--format", "bhv"), "--format", "bvh", "bvh, trc, csv, naoqi"),
        (("clips", ds, "--status", "rejectd"), "--status", "rejected", "accepted, rejected"),
        (("build-dataset", str(videos), out, "--detector", "blazpose"), "--detector", "blazepose",
         "mediapipe"),
        (("build-dataset", str(videos), out, "--lifter", "learnd"), "--lifter", "learned",
         "geometric"),
        (("build-dataset", str(videos), out, "--executor", "rey"), "--executor", "ray", "local"),
        (("replay", str(timeline), "--backend", "smi", "--out", str(tmp_path / "v.mp4")),
         "--backend", "sim", "record"),
    ]  # fmt: skip
    done = run_each([("gesturebank", *c[0]) for c in cases], columns=200)
    for (args, flag, closest, listed), r in zip(cases, done, strict=True):
        assert r.returncode == 2, (args, r.stderr)
        assert flag in r.stderr and f"did you mean {closest!r}?" in r.stderr, (args, r.stderr)
        assert listed in r.stderr, (args, r.stderr)


def test_unknown_plugin_names_are_one_usage_error_before_any_take(tmp_path: Path) -> None:
    videos, out = tmp_path / "videos", tmp_path / "out"
    (videos / "s1").mkdir(parents=True)
    (videos / "s1" / "a.mp4").write_bytes(b"")  # would fail as a take: no take may start
    cases = [
        (("--detector", "foo"), "unknown detector 'foo' (--detector); one of: blazepose"),
        (("--lifter", "bar"), "unknown lifter 'bar' (--lifter); one of: blazepose-world"),
        (("--set", "robot.profile=nao"), "unknown robot profile 'nao'"),
    ]
    done = run_each([("build-dataset", str(videos), str(out), "--quiet", *o) for o, _ in cases])
    for (option, message), r in zip(cases, done, strict=True):
        assert r.returncode == 2, (option, r.stdout, r.stderr)
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and message in lines[0], r.stderr
        assert not (out / "takes").exists()


def test_qc_thresholds_survive_the_next_build(
    demo_dataset: Path, samples: Path, tmp_path: Path
) -> None:
    """`qc --set` is saved in dataset.json, and a re-run of build-dataset keeps it (it used to
    judge again with the defaults, silently undoing the verdicts)."""
    import json
    import shutil

    import pyarrow.parquet as pq

    out = tmp_path / "ds"
    shutil.copytree(demo_dataset, out)

    def statuses() -> set[str]:
        rows = pq.read_table(out / "manifest.parquet").to_pylist()
        return {r["qc_status"] for r in rows if r["kind"] == "clip"}

    def saved() -> float:
        return json.loads((out / "dataset.json").read_text())["config"]["qc"]["max_people"]

    assert "accepted" in statuses()
    r = run("gesturebank", "qc", str(out), "--set", "qc.max_people=0.5")  # all: "too many people"
    assert r.returncode == 0, r.stderr
    assert statuses() == {"rejected"} and saved() == 0.5
    r = run("build-dataset", str(samples / "talking"), str(out), "--quiet")
    assert r.returncode == 0, r.stderr
    assert statuses() == {"rejected"} and saved() == 0.5  # every take skipped, verdicts kept
    r = run("build-dataset", str(samples / "talking"), str(out), "--quiet",
            "--set", "qc.max_people=5")  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "accepted" in statuses() and saved() == 5  # the command line still wins


def test_build_dataset_of_one_video_file_and_the_qc_summary(samples: Path, tmp_path: Path) -> None:
    """Issue 33 item 7: a single video file is a valid input; `qc` prints the build's summary."""
    video = samples / "talking" / "lab" / "cam01_arctic.mp4"
    out = tmp_path / "one"
    cmd = [str(BIN / "gesturebank"), "build-dataset", str(video), str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600, check=False)
    assert r.returncode == 0, r.stderr
    built = [ln for ln in r.stdout.splitlines() if ln.startswith("cam01_arctic: ")]
    assert len(built) == 1 and "clips kept" in built[0], r.stdout
    r = run("gesturebank", "clips", str(out), "--csv")
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines()[1].startswith("cam01_arctic__c000,cam01_arctic,lab,")
    r = run("gesturebank", "qc", str(out))
    assert r.returncode == 0, r.stderr
    assert [ln for ln in r.stdout.splitlines() if ln.startswith("cam01_arctic: ")] == built
    assert "clips kept" in r.stdout and "rejected" in r.stdout and "QC dashboard:" in r.stdout


def test_the_detection_cache_is_shown_counted_and_cleared(samples: Path, tmp_path: Path) -> None:
    """Issue 44: the detection cache was invisible. `cache info` says where it is and what it
    holds, the build's summary counts the takes whose detections came from it, `cache clear`
    empties it."""
    cache = tmp_path / "cache"
    env = {**os.environ, "GESTUREBANK_CACHE": str(cache), "COLUMNS": "200"}

    def gb(*args: str) -> subprocess.CompletedProcess[str]:
        cmd = [str(BIN / "gesturebank"), *args]
        return subprocess.run(
            cmd, capture_output=True, text=True, timeout=600, check=False, env=env
        )

    video = samples / "talking" / "lab" / "cam01_arctic.mp4"
    out = tmp_path / "ds"
    fast = ("--set", "video.max_fps=10")  # a third of the frames detected: the cache is the point
    r = gb("build-dataset", str(video), str(out), *fast)
    assert r.returncode == 0, r.stderr
    assert "from the cache" not in r.stdout  # a first build detects
    env["COLUMNS"] = "80"
    r = gb("cache", "info")
    assert r.returncode == 0, r.stderr
    # at 80 columns: the path whole on a line of its own (its note was appended to it, one long
    # line the terminal wrapped), every other line within 80
    lines = r.stdout.splitlines()
    assert lines[0] == f"detection cache: {cache}", r.stdout
    assert "set by $GESTUREBANK_CACHE" in lines[1] and all(len(ln) <= 80 for ln in lines[1:])
    assert "1 entry, " in r.stdout
    env["COLUMNS"] = "200"
    r = gb("build-dataset", str(video), str(out), "--force", *fast)
    assert r.returncode == 0, r.stderr
    assert "1 of 1 takes built took their detections from the cache" in r.stdout, r.stdout
    r = gb("cache", "clear")
    assert r.returncode == 0 and "removed 1 entry " in r.stdout, r.stdout
    assert list(cache.iterdir()) == []
    assert "0 entries, 0 B" in gb("cache", "info").stdout
