"""The fault battery: bad inputs and hostile events, each met as a user runs the commands.

Every row runs the real command line (`build-dataset`, `gesturebank …`) in a subprocess on real
media (a short take made from the sample clips by `gesturebank.footage`) and reads what a user
would see: the exit code, the message (one line, no traceback), whether the other takes still
built, and whether anything was lost or half-written (a file under a final name that does not
load, a finished take changed, a process left running). A row is good when all of it holds;
the script exits 1 when a row is not, so `make test` (which runs `--quick`) fails.

    .venv/bin/python benchmarks/faults.py [--quick] [--out DIR]

--quick: the takes at 3.5 s (the full run: 7 s), one worker where the row allows it, 4 takes
(not 6) in the signal rows, whose rerun may use the detection cache.
--jobs N: rows run N at a time (default 2); each row's processes carry a tag of their own, so
a row only ever finds (and cleans up) its own.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank import footage
from gesturebank.samples import default_samples_dir

BIN = Path(sys.executable).parent
TAG = "GESTUREBANK_FAULT_TAG"  # set in every command's environment: its processes are found by it
FOLDERS = itertools.count(1)  # numbers the rows' folders, shared by rows running side by side
ONE_SUBJECT = threading.Lock()  # the train rows share one dataset, built by whichever comes first


@dataclass(frozen=True)
class Run:
    code: int
    out: str
    err: str

    @property
    def message(self) -> str:
        lines = [ln for ln in self.err.splitlines() if ln.strip()]
        return lines[0] if lines else ""

    @property
    def one_line(self) -> bool:
        """No traceback, and the error (if any) on one line."""
        errors = [ln for ln in self.err.splitlines() if ln.startswith("error:")]
        return "Traceback" not in self.err + self.out and len(errors) <= 1


@dataclass(frozen=True)
class Row:
    case: str
    code: int
    message: str
    others: str  # "yes", "no", or "–" when the row has no other take
    intact: str  # "yes" or what was lost / half-written
    good: bool


@dataclass
class Bench:
    root: Path
    samples: Path
    take: Path  # a short real take with speech
    quick: bool
    tag: str = "0"  # this row's value of TAG

    def folder(self, name: str) -> Path:
        path = self.root / f"{next(FOLDERS):02d}-{name}"
        path.mkdir(parents=True)
        return path

    def videos(self, name: str, *, copies: int = 1) -> Path:
        """A videos folder with `copies` good takes (symlinks to the one real take)."""
        videos = self.folder(name) / "videos"
        for i in range(copies):
            (videos / f"good{i}").mkdir(parents=True)
            (videos / f"good{i}" / f"good{i}.mp4").symlink_to(self.take)
        return videos

    def run(self, *args: str | Path, **kw: object) -> Run:
        done = subprocess.run(
            [str(a) for a in args],
            capture_output=True,
            text=True,
            env=env(self.tag),
            timeout=600,
            **kw,
        )
        return Run(done.returncode, done.stdout, done.stderr)

    def build(self, videos: Path, out: Path, *extra: str) -> Run:
        return self.run(BIN / "build-dataset", videos, out, "--workers", "1", *extra)


def env(tag: str) -> dict[str, str]:
    return os.environ | {TAG: tag, "PYTHONIOENCODING": "utf-8", "COLUMNS": "200"}


def tagged_pids(tag: str) -> list[int]:
    """Processes (other than this one) whose environment carries TAG = `tag`."""
    pids = []
    for proc in Path("/proc").iterdir():
        if proc.name.isdigit() and int(proc.name) != os.getpid():
            try:
                if f"{TAG}={tag}".encode() in (proc / "environ").read_bytes().split(b"\0"):
                    pids.append(int(proc.name))
            except OSError:
                continue
    return pids


def built_takes(out: Path) -> set[str]:
    """Takes whose record says they are done (read as a user's script would)."""
    done = set()
    for path in (out / "takes").glob("*.json") if (out / "takes").is_dir() else ():
        record = json.loads(path.read_text())
        if not record.get("failed"):
            done.add(record["take_id"])
    return done


def damage(out: Path) -> str:
    """What is broken under a final name in a dataset folder: files that do not load."""
    bad = []
    for path in out.rglob("*.npz") if out.is_dir() else ():
        try:
            with np.load(path, allow_pickle=False) as d:
                [d[k] for k in d.files]
        except Exception:  # any failure to load is the finding
            bad.append(path.name)
    for path in out.rglob("*.json") if out.is_dir() else ():
        try:
            json.loads(path.read_text())
        except (ValueError, UnicodeDecodeError):
            bad.append(path.name)
    return f"broken: {', '.join(bad)}" if bad else "yes"


def snapshot(out: Path) -> dict[str, bytes]:
    """The clip arrays of the finished takes (their records may be refreshed; arrays never).
    A take being written sits in a hidden folder (`.<take>.tmp`) that pathlib's glob matches
    too: it is not finished, and it is gone once renamed, so it is left out."""
    return {
        str(p.relative_to(out)): p.read_bytes()
        for p in sorted(out.glob("takes/*/*.npz"))
        if not p.parent.name.startswith(".")
    }


def row(
    case: str, run: Run, *, code: int, says: str, others: str = "–", intact: str = "yes"
) -> Row:
    """Good when the exit code is `code`, no traceback and at most one error line, a line of the
    output contains `says`, the other takes built (when there are any) and nothing was lost."""
    lines = [ln.strip() for ln in f"{run.err}\n{run.out}".splitlines() if ln.strip()]
    said = next((ln for ln in lines if says.lower() in ln.lower()), None)
    good = run.code == code and run.one_line and said is not None
    good &= others in ("yes", "–") and intact == "yes"
    return Row(case, run.code, said or run.message, others, intact, good)


# -- bad inputs beside a good take -----------------------------------------------------------


def bad_file(b: Bench, case: str, make: Callable[[Path], None], says: str, code: int = 1) -> Row:
    """A bad video beside a good take: the bad take fails (or is dropped) with its reason in the
    summary; the good one builds."""
    videos = b.videos(case)
    (videos / "bad").mkdir()
    make(videos / "bad" / "bad.mp4")
    out = videos.parent / "out"
    run = b.build(videos, out)
    others = "yes" if "good0__good0" in built_takes(out) else "no"
    line = next((ln for ln in run.out.splitlines() if "bad__bad:" in ln), "")
    run = Run(run.code, run.out, line + "\n" + run.err)
    return row(case, run, code=code, says=says, others=others, intact=damage(out))


def empty(path: Path) -> None:
    path.write_bytes(b"")


def random_bytes(path: Path) -> None:
    path.write_bytes(np.random.default_rng(0).bytes(50_000))


def truncated(b: Bench) -> Callable[[Path], None]:
    return lambda p: p.write_bytes(b.take.read_bytes()[: b.take.stat().st_size // 3])


def audio_only(b: Bench) -> Callable[[Path], None]:
    def make(path: Path) -> None:
        import av

        with av.open(str(b.take)) as src, av.open(str(path), "w") as dst:
            a = src.streams.audio[0]
            stream = dst.add_stream("aac", rate=a.rate)
            for frame in src.decode(a):
                frame.pts = None
                for packet in stream.encode(frame):
                    dst.mux(packet)
            for packet in stream.encode(None):
                dst.mux(packet)

    return make


def one_frame(b: Bench) -> Callable[[Path], None]:
    def make(path: Path) -> None:
        frames = footage.load(b.take, seconds=0.05)
        one = footage.Frames(frames.images[:1], frames.fps)
        footage.write(one, path, speech=np.zeros(1600, np.float32))

    return make


def unicode_path(b: Bench, case: str) -> Row:
    videos = b.folder("unicode") / "videos"
    (videos / "ünï cödé").mkdir(parents=True)
    (videos / "ünï cödé" / "ünï cödé.mp4").symlink_to(b.take)
    out = videos.parent / "out"
    run = b.build(videos, out)
    ids = built_takes(out)  # transliterated, not "_n_c_d_"
    others = "yes" if ids and all(i.startswith("uni") for i in ids) else f"no: {sorted(ids)}"
    return row(case, run, code=0, says="uni_code__uni_code:", others=others, intact=damage(out))


def short_audio(b: Bench, case: str) -> Row:
    """A 1.5 s .wav beside the take: the take keeps 1.5 s, and says so."""
    from scipy.io import wavfile

    videos = b.videos("short-audio")
    speech = footage.looped_speech([b.samples / p for p in footage.SPEECH], seconds=1.5)
    wavfile.write(videos / "good0" / "good0.wav", footage.SPEECH_RATE, speech)
    out = videos.parent / "out"
    return row(case, b.build(videos, out), code=0, says="drops",
               intact=damage(out))  # fmt: skip


def subjects_typo(b: Bench, case: str) -> Row:
    videos = b.videos("subjects", copies=1)
    (videos / "subjects.csv").write_text("take,subject\ngood_0,alice\ngood0,bob\ngood0,carol\n")
    out = videos.parent / "out"
    return row(case, b.build(videos, out), code=0, says="good0",
               intact=damage(out))  # fmt: skip


def out_inside_videos(b: Bench, case: str) -> Row:
    videos = b.videos("out-inside")
    out = videos / "dataset"
    first = b.build(videos, out)
    (out / "render.mp4").symlink_to(b.take)  # e.g. a replay rendered into the dataset folder
    again = b.build(videos, out)
    others = "yes" if built_takes(out) == {"good0__good0"} else f"no: {sorted(built_takes(out))}"
    code = first.code or again.code
    return row(case, Run(code, again.out, again.err), code=0, says="good0__good0:",
               others=others, intact=damage(out))  # fmt: skip


def usage(b: Bench, case: str, *extra: str, says: str, config: str | None = None) -> Row:
    videos = b.videos(case.split()[0].strip("-:"))
    if config is not None:
        (videos.parent / "bad.toml").write_text(config)
        extra = (*extra, "--config", str(videos.parent / "bad.toml"))
    out = videos.parent / "out"
    run = b.build(videos, out, *extra)
    intact = "yes" if not built_takes(out) else "built although refused"
    return row(case, run, code=2, says=says, intact=intact)


# -- the output folder ------------------------------------------------------------------------


def out_is_a_file(b: Bench, case: str) -> Row:
    videos = b.videos("out-file")
    out = videos.parent / "out"
    out.write_text("not a folder")
    return row(case, b.build(videos, out), code=2, says=str(out))


@contextmanager
def tmpfs(where: Path, *options: str) -> Iterator[Path | None]:
    """A small tmpfs (root only); None where it cannot be mounted."""
    where.mkdir(parents=True)
    mounted = (
        os.geteuid() == 0
        and subprocess.run(
            ["mount", "-t", "tmpfs", "-o", ",".join(options), "tmpfs", str(where)],
            capture_output=True,
        ).returncode
        == 0
    )
    try:
        yield where if mounted else None
    finally:
        if mounted:
            subprocess.run(["umount", "-l", str(where)], capture_output=True)


def unwritable(b: Bench, case: str) -> Row:
    videos = b.videos("unwritable")
    with tmpfs(videos.parent / "ro", "ro", "size=1m") as ro:
        if ro is None:  # not root: a folder without write permission does it
            ro = videos.parent / "ro"
            ro.chmod(0o500)
        out = ro / "out"
        return row(case, b.build(videos, out), code=2, says=str(ro))


def disk_full(b: Bench, case: str) -> Row:
    videos = b.videos("disk-full", copies=2)
    with tmpfs(videos.parent / "small", "size=192k") as small:
        if small is None:
            return Row(case, -1, "skipped: needs root for a small tmpfs", "–", "–", True)
        out = small / "out"
        run = b.build(videos, out)
        intact = damage(out)
    return row(case, run, code=1, says="space", intact=intact)


# -- signals and concurrent writers -------------------------------------------------------------


def start_build(b: Bench, videos: Path, out: Path, workers: int, *extra: str) -> subprocess.Popen:
    return subprocess.Popen(
        [BIN / "build-dataset", videos, out, "--workers", str(workers), "--no-cache", *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env(b.tag),
        start_new_session=True,  # a signal to it alone, as `kill PID` would send
    )


def wait_for_a_take(out: Path, proc: subprocess.Popen, timeout: float = 300) -> None:
    end = time.monotonic() + timeout
    while not built_takes(out) and proc.poll() is None and time.monotonic() < end:
        time.sleep(0.2)


def killed(b: Bench, case: str, sig: signal.Signals) -> Row:
    # work left when the signal comes (2 building, 2 waiting with --quick)
    videos = b.videos(sig.name.lower(), copies=4 if b.quick else 6)
    out = videos.parent / "out"
    proc = start_build(b, videos, out, 2)
    wait_for_a_take(out, proc)
    before = snapshot(out)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=120)
    deadline = time.monotonic() + 5
    while tagged_pids(b.tag) and time.monotonic() < deadline:
        time.sleep(0.2)
    orphans = tagged_pids(b.tag)
    for pid in orphans:  # leave the machine clean for the next row
        os.kill(pid, signal.SIGKILL)
    kept = snapshot(out)
    intact = "yes" if all(kept.get(k) == v for k, v in before.items()) else "a built take changed"
    if orphans:
        intact = f"{len(orphans)} processes alive 5 s later"
    # --quick: the rerun may read the detections cached by the other rows (the same take)
    resumed = b.build(videos, out, *(() if b.quick else ("--no-cache",)))
    copies = len(list(videos.iterdir()))
    others = "yes" if resumed.code == 0 and len(built_takes(out)) == copies else "no (rerun)"
    run = Run(proc.returncode, stdout, stderr)
    if sig == signal.SIGKILL:  # it cannot speak: what the rerun did is the message
        built = len(built_takes(out)) - len({k.split("/")[0] for k in before})
        run = Run(proc.returncode, "", f"(no message) the rerun built the other {built} takes")
    # SIGKILL: the process cannot speak; SIGINT and SIGTERM: 128 + signal, "finished takes are kept"
    code, says = (-9, "rerun") if sig == signal.SIGKILL else (128 + sig.value, "takes are kept")
    return row(case, run, code=code, says=says, others=others, intact=intact)


def two_writers(b: Bench, case: str) -> Row:
    """A second build into the OUT_DIR a first one is writing. The first has many takes (cache
    off) and is stopped with Ctrl-C once the second has answered, so the second surely meets
    it however slowly it starts; a second that finds no writer makes the row inconclusive."""
    videos = b.videos("two-writers", copies=12)
    out = videos.parent / "out"
    first = start_build(b, videos, out, 1)
    deadline = time.monotonic() + 120
    while not (out / "takes").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    second = b.run(BIN / "build-dataset", videos, out, "--quiet", "--set", "processing.cutoff_hz=6")
    still_writing = first.poll() is None
    first.send_signal(signal.SIGINT)
    first.communicate(timeout=600)
    if not still_writing:
        return Row(case, second.code, "inconclusive: the first build ended first", "–", "–", False)
    return row(case, second, code=2, says="pid", intact=damage(out))


# -- other commands -----------------------------------------------------------------------------


def angles_csv(path: Path, *, scale: float = 1.0, times: np.ndarray | None = None) -> Path:
    """A gentle sway around the neutral pose (radians), `scale`d: 57.3 makes it degrees."""
    from gesturebank.robot import pepper, timeline

    t = np.arange(0, 2, 0.01) if times is None else times
    angles = pepper.clamp(pepper.neutral_pose() + 0.2 * np.sin(t)[:, None]) * scale
    return timeline.write_timeline(path, timeline.Timeline.of(t, angles))


def replay(
    b: Bench, case: str, csv: Path, says: str, *, backend: str = "sim", url: str = ""
) -> Row:
    out = csv.with_suffix(".mp4")
    target = ["--url", url] if url else ["--out", str(out)]
    run = b.run(BIN / "gesturebank", "replay", csv, "--backend", backend, *target)
    intact = "yes" if not out.exists() else "an output was written"
    return row(case, run, code=1 if url else 2, says=says, intact=intact)


def train(b: Bench, case: str, *extra: str, says: str) -> Row:
    """`train` on a one-subject dataset (built once): refusals come as one line, before any
    training, and leave no model folder behind."""
    out = b.root / "one-subject" / "out"
    with ONE_SUBJECT:
        if not out.is_dir():
            b.build(b.videos("one-subject"), out)
    model = b.folder(case.split(":")[1].strip().split()[0]) / "model"
    run = b.run(BIN / "gesturebank", "train", out, "--out", model, "--quiet", *extra)
    intact = "yes" if not model.exists() else "a model folder was written"
    return row(case, run, code=2, says=says, intact=intact)


@dataclass(frozen=True)
class Case:
    name: str
    make: Callable[[Bench, str], Row]

    def run_in(self, b: Bench) -> Row:
        return self.make(b, self.name)


def cases(bench: Bench) -> list[Case]:
    """The rows; each is made with the Bench of its own run (its own process tag)."""
    replays = bench.folder("replay")
    gap = np.concatenate([np.arange(0, 1, 0.01), np.arange(6, 7, 0.01)])
    far = np.arange(1000, 1002, 0.01)
    return [
        Case("zero-byte video", lambda b, n: bad_file(b, n, empty, "bad.mp4")),
        Case("random bytes", lambda b, n: bad_file(b, n, random_bytes, "bad.mp4")),
        Case("truncated video", lambda b, n: bad_file(b, n, truncated(b), "bad.mp4")),
        Case("audio only", lambda b, n: bad_file(b, n, audio_only(b), "no video")),
        Case("one frame", lambda b, n: bad_file(b, n, one_frame(b), "too short", code=0)),
        Case("unicode path ünï cödé", unicode_path),
        Case("1.5 s .wav beside the video", short_audio),
        Case("subjects.csv: typo, duplicates", subjects_typo),
        Case("OUT_DIR inside VIDEOS_DIR", out_inside_videos),
        Case("--detector foo", lambda b, n: usage(b, n, "--detector", "foo", says="foo")),
        Case("bad --set", lambda b, n: usage(
            b, n, "--set", "processing.cutoff_hz=x", says="cutoff")),
        Case("bad TOML", lambda b, n: usage(
            b, n, says="bad.toml", config="[processing\ncutoff_hz")),
        Case("OUT_DIR is a file", out_is_a_file),
        Case("OUT_DIR unwritable", unwritable),
        Case("disk full (192 kB tmpfs)", disk_full),
        Case("two writers, one OUT_DIR", two_writers),
        *(Case(f"{sig.name} mid-build, 2 workers", lambda b, n, sig=sig: killed(b, n, sig))
          for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL)),
        Case("train: SI on 1 subject", lambda b, n: train(b, n, "--variant", "si",
                                                          says="at least 3 subjects")),
        Case("train: --out under a file", lambda b, n: train(
            b, n, "--variant", "sd", "--subject", "good0", "--out", str(b.take / "model"),
            says="not a folder")),
        Case("replay: degrees CSV", lambda b, n: replay(
            b, n, angles_csv(replays / "deg.csv", scale=57.3), "degrees")),
        Case("replay: 5 s gap", lambda b, n: replay(
            b, n, angles_csv(replays / "gap.csv", times=gap), "gap")),
        Case("replay: starts at 1000 s", lambda b, n: replay(
            b, n, angles_csv(replays / "far.csv", times=far), "1000")),
        Case("replay: no robot listening", lambda b, n: replay(
            b, n, angles_csv(replays / "ok.csv"), "127.0.0.1", backend="naoqi",
            url="tcp://127.0.0.1:9")),
    ]  # fmt: skip


def make_take(samples: Path, root: Path, seconds: float) -> Path:
    """A short real take: Pose2Sim cam01 at half size, ping-ponged, with real speech."""
    frames = footage.rescale(footage.load(samples / footage.CAM01), height=540)
    frames = footage.ping_pong(frames, seconds=seconds)
    speech = footage.looped_speech([samples / p for p in footage.SPEECH], seconds=seconds)
    return footage.write(frames, root / "take.mp4", speech=speech)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="short takes, the same rows")
    parser.add_argument("--out", type=Path, help="keep the work here (default: a temp folder)")
    parser.add_argument("--only", help="run the rows whose input contains this text")
    parser.add_argument("--jobs", type=int, default=2, help="rows run at a time (default 2)")
    args = parser.parse_args()
    samples = default_samples_dir()
    with tempfile.TemporaryDirectory() as tmp:
        root = args.out or Path(tmp)
        root.mkdir(parents=True, exist_ok=True)
        b = Bench(
            root / uuid.uuid4().hex[:6],
            samples,
            make_take(samples, root, 3.5 if args.quick else 7.0),
            args.quick,
        )
        chosen = [c for c in cases(b) if not args.only or args.only.lower() in c.name.lower()]

        def run(numbered: tuple[int, Case]) -> Row:
            i, case = numbered
            r = case.run_in(dataclasses.replace(b, tag=str(i)))
            Console(stderr=True).print(f"{r.case}: {'good' if r.good else 'BAD'}")
            return r

        with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            rows = list(pool.map(run, enumerate(chosen, start=1)))
    table = Table(title="fault battery: input × exit code × message × others built? × intact?")
    for col in ("input", "exit", "message", "others built", "nothing lost", "good"):
        table.add_column(col, overflow="fold")
    for r in rows:
        message = r.message.replace(f"{b.root}/", "")  # paths inside the battery's folder
        table.add_row(r.case, str(r.code), message, r.others, r.intact, "good" if r.good else "BAD")
    Console(width=200).print(table)
    bad = [r.case for r in rows if not r.good]
    if bad:
        print(f"not good: {', '.join(bad)}")
        sys.exit(1)


if __name__ == "__main__":
    main()
