"""The dataset lock between real processes: the holder is named, a dead holder's lock is free."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from gesturebank.datasets.lock import dataset_lock
from gesturebank.errors import InputError

HOLD = """
import sys
from gesturebank.datasets.lock import dataset_lock
with dataset_lock(sys.argv[1]):
    print("held", flush=True)
    sys.stdin.read()
"""


def test_the_holder_is_named_and_its_death_frees_the_lock(tmp_path: Path) -> None:
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLD, str(tmp_path)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline() == "held\n"
        with pytest.raises(InputError, match=rf"^{tmp_path}: .* \(pid {holder.pid}\) is writing"):
            with dataset_lock(tmp_path):
                pass
    finally:
        holder.kill()  # SIGKILL: no clean-up of its own, the kernel releases the lock
        holder.wait()
    assert (tmp_path / ".lock").read_text() == f"{holder.pid}\n"  # stale pid left behind
    with dataset_lock(tmp_path):
        assert (tmp_path / ".lock").read_text() == f"{os.getpid()}\n"
    assert not (tmp_path / ".lock").exists()  # issue 44: a finished holder leaves no lock file
    with dataset_lock(tmp_path):  # released on leaving
        pass
    assert not (tmp_path / ".lock").exists()


def test_a_missing_folder_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"missing/\.lock: cannot open the dataset's lock file"):
        with dataset_lock(tmp_path / "missing"):
            pass


def test_a_finished_build_leaves_no_lock(demo_dataset: Path) -> None:
    """Issue 44: a `.lock` with a process id stayed in every finished dataset."""
    assert (demo_dataset / "manifest.parquet").is_file()  # the premise: a built dataset
    assert not (demo_dataset / ".lock").exists()


def test_a_removed_lock_file_is_locked_anew(tmp_path: Path) -> None:
    """A writer whose lock file was removed by the finishing holder locks the new file, so two
    writers never hold two different files: the second one is refused while the first holds."""
    with dataset_lock(tmp_path):
        inode = (tmp_path / ".lock").stat().st_ino
        with pytest.raises(InputError, match="is writing this dataset"):
            with dataset_lock(tmp_path):
                pass
        assert (tmp_path / ".lock").stat().st_ino == inode
