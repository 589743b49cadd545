"""build-dataset under faults, as real processes: a second writer, SIGKILL, SIGTERM and SIGINT of
the build alone, a full disk (RLIMIT_FSIZE: writes beyond it fail with EFBIG, as ENOSPC would)."""

import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pyarrow.parquet as pq
import pytest

BIN = Path(sys.executable).parent
GONE_S = 5.0  # the acceptance bound: no process of a killed build's tree after this


def _ppid_and_state(pid: int) -> tuple[int, str] | None:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = stat[stat.rindex(")") + 2 :].split()  # the name may hold spaces
    return int(fields[1]), fields[0]


def tree(root: int) -> set[int]:
    """`root` and all its descendants, by pid (from /proc)."""
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and (info := _ppid_and_state(int(entry.name))):
            parents[int(entry.name)] = info[0]
    found = {root}
    while grown := {pid for pid, ppid in parents.items() if ppid in found} - found:
        found |= grown
    return found


def alive(pids: set[int]) -> set[int]:
    """Those of `pids` still running (a zombie runs nothing: it waits to be reaped)."""
    return {pid for pid in pids if (info := _ppid_and_state(pid)) and info[1] != "Z"}


def wait_for(condition: Callable[[], object], what: str, timeout_s: float = 180) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"gave up waiting for {what}"
        time.sleep(0.02)


def kill_all(pids: set[int]) -> None:
    """Clean up after a failing test: no orphan may outlive it."""
    for pid in alive(pids):
        os.kill(pid, signal.SIGKILL)


def _cmdline(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""


def workers_of(pid: int) -> set[int]:
    """The pool workers in the build's tree: the fork server's children (forked, not exec'd,
    so they share its command line; they have no children of their own)."""
    procs = tree(pid)
    servers = {p for p in procs if b"multiprocessing.forkserver" in _cmdline(p)}
    return {p for p in procs if (info := _ppid_and_state(p)) and info[0] in servers}


def summary_counts(stdout: str) -> tuple[int, int, int]:
    """(takes built, skipped, failed): the first row of the summary table."""
    # the first line of whole numbers under the table's header (no vertical rules: issue 44)
    row = re.search(r"^\s*(\d+)\s+(\d+)\s+(\d+)\s+\d+\s", stdout, flags=re.MULTILINE)
    assert row, stdout
    built, skipped, failed = (int(g) for g in row.groups())
    return built, skipped, failed


def test_a_second_writer_gets_one_line_with_the_holders_pid(
    samples: Path, demo_dataset: Path, tmp_path: Path
) -> None:
    """Two builds (or a build and `qc`) into one OUT_DIR used to mix configurations silently."""
    videos, out = samples / "talking", tmp_path / "out"
    shutil.copytree(demo_dataset, out)
    build = [str(BIN / "build-dataset"), str(videos), str(out), "--workers", "1", "--quiet"]
    holder = subprocess.Popen(
        [*build, "--force", "--no-cache"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    pids = tree(holder.pid)
    try:
        lock = out / ".lock"
        wait_for(lambda: lock.is_file() and lock.read_text().strip() == str(holder.pid), "lock")
        second = [
            [*build, "--workers", "2", "--set", "processing.cutoff_hz=6"],
            [str(BIN / "gesturebank"), "qc", str(out)],
        ]
        for cmd in second:
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
            assert r.returncode == 2, (cmd, r.stdout, r.stderr)
            assert r.stderr.strip().splitlines() == [
                f"error: {out}: another gesturebank process (pid {holder.pid}) is writing this "
                "dataset; wait for it to finish or stop it"
            ]
        assert holder.poll() is None, "the first build must still hold the lock"
        pids |= tree(holder.pid)
        os.kill(holder.pid, signal.SIGKILL)
        holder.wait()
        wait_for(lambda: not alive(pids), "the killed build's processes to go", GONE_S)
        # its lock file still names it; the kernel released the lock: the next writer takes over
        assert lock.read_text().strip() == str(holder.pid)
        r = subprocess.run(
            [str(BIN / "gesturebank"), "qc", str(out)], capture_output=True, text=True, check=False
        )
        assert r.returncode == 0, r.stderr
        assert not lock.exists(), "a finished writer leaves no lock behind (issue 44)"
    finally:
        holder.kill()  # no-op once it has exited
        kill_all(pids)


def test_no_orphan_process_5_s_after_sigkill_of_a_2_worker_build(
    samples: Path, tmp_path: Path
) -> None:
    """The fork server and its workers used to live on, finish their takes, then idle."""
    out = tmp_path / "out"
    cmd = [str(BIN / "build-dataset"), str(samples / "talking"), str(out), "--workers", "2"]
    proc = subprocess.Popen(
        [*cmd, "--no-cache", "--quiet"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    pids: set[int] = set()
    try:
        wait_for(lambda: len(workers_of(proc.pid)) == 2, "two workers")
        pids = tree(proc.pid)
        assert len(pids) >= 4  # the build, the fork server, two workers (+ resource tracker)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        deadline = time.monotonic() + GONE_S
        while alive(pids) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not alive(pids), f"orphans of the killed build: {sorted(alive(pids))}"
    finally:
        kill_all(pids)


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_signal_to_the_build_alone_stops_it_and_counts_what_was_built(
    samples: Path, tmp_path: Path, sig: signal.Signals, code: int
) -> None:
    """As `kill PID` or a job scheduler sends it (not to the whole process group as Ctrl-C):
    SIGTERM used to kill it without the summary, SIGINT to let the workers build every take
    after the summary's count ("built 0" with 3 takes on disk)."""
    out = tmp_path / "out"
    cmd = [str(BIN / "build-dataset"), str(samples / "talking"), str(out), "--workers", "2"]
    proc = subprocess.Popen(
        [*cmd, "--no-cache"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    pids: set[int] = set()
    try:
        wait_for(lambda: list((out / "takes").glob("*.json")), "the first take")
        pids = tree(proc.pid)
        os.kill(proc.pid, sig)
        stdout, stderr = proc.communicate(timeout=300)
        wait_for(lambda: not alive(pids), "the build's processes to go", GONE_S)
    finally:
        kill_all(pids)
    assert proc.returncode == code, stderr
    assert "interrupted: finished takes are kept; run the same command to resume" in stdout
    assert "Traceback" not in stderr
    built, skipped, failed = summary_counts(stdout)
    records = {p.stem for p in (out / "takes").glob("*.json")}
    assert built + failed == len(records) and skipped == 0, stdout
    assert len(records) < 3, "the signal should stop the build before its end"
    assert not list((out / "takes").glob(".*"))  # the stopped workers' temporaries are gone
    manifest = pq.read_table(out / "manifest.parquet").to_pylist()
    assert {r["take_id"] for r in manifest} == records


@pytest.mark.parametrize(
    ("limit", "code"),
    [
        (150_000, 1),  # a clip (~300 kB) does not fit: that take fails, the summary says why
        (4_000, 2),  # nor dataset.json: one error line after the summary
    ],
)
def test_a_full_disk_fails_in_one_line_with_nothing_half_written(
    samples: Path, tmp_path: Path, limit: int, code: int
) -> None:
    videos, out = tmp_path / "videos", tmp_path / "out"
    videos.mkdir()
    (videos / "cam01.mp4").symlink_to(samples / "talking/lab/cam01_arctic.mp4")

    def small_disk() -> None:  # Python ignores SIGXFSZ, so a write beyond the limit gets EFBIG
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    env = {**os.environ, "GESTUREBANK_CACHE": str(tmp_path / "cache")}  # a miss: it writes too
    r = subprocess.run(
        [str(BIN / "build-dataset"), str(videos), str(out), "--workers", "1"],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        env=env,
        preexec_fn=small_disk,
    )
    assert r.returncode == code, r.stdout + r.stderr
    assert "Traceback" not in r.stdout + r.stderr
    assert summary_counts(r.stdout) == (0, 0, 1)  # the summary is printed
    flat = " ".join(r.stdout.split())
    assert f"failed cam01: {out / 'takes' / 'cam01'}: cannot write (File too large)" in flat
    if code == 2:
        last = r.stderr.strip().splitlines()[-1]
        assert last.startswith("error: ") and "cannot write (File too large)" in last
        assert "finished takes are kept" in last
    else:
        rows = pq.read_table(out / "manifest.parquet").to_pylist()
        assert [(row["take_id"], row["qc_status"]) for row in rows] == [("cam01", "failed")]
    assert not list(out.rglob("*.npz"))  # no clip under a final name
    assert not [p for p in out.rglob(".*") if p.name != ".lock"]  # no temporaries left
