"""Same outputs: build the same takes with this checkout and with another commit, and compare.

A refactor that should change nothing (issue 34's house step) is checked here: every array of
every clip equal within --atol (1e-9); every JSON and Parquet record equal once the fields that
name a time or a place (build times, durations, the output folder) are left out; every other
file (the QC pages, the dataset card, previews) byte for byte, its folder's name aside.

    .venv/bin/python benchmarks/same_outputs.py --against house-base
    .venv/bin/python benchmarks/same_outputs.py --against HEAD~3 --takes DIR_OR_FILE ...

The other commit is checked out into a temporary git worktree and run with this interpreter
(PYTHONPATH=that tree), each build with the default config and one worker; detections come from
the detection cache, keyed by the video's checksum and the detector's settings (pass
--no-cache to run the detector in both). The takes default to the talking demo (`make demo`'s)
and the first motion-capture sample; --quick builds the outdoor demo clip against HEAD.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
from rich.console import Console
from rich.table import Table

from gesturebank.samples import default_samples_dir, fetch_samples

REPO = Path(__file__).resolve().parents[1]
# Fields that differ between two builds of the same takes without the motion differing.
UNCOMPARED = {".lock"}  # the build's lock file: who held it
VOLATILE = {
    "built_at",
    "created",
    "started",
    "finished",
    "seconds",
    "elapsed_s",
    "wall_s",
    "mouth_seconds",
    "path",
}


def build_command(tree: Path) -> list[str]:
    """The interpreter call that runs `tree`'s own build-dataset entry point."""
    scripts = tomllib.loads((tree / "pyproject.toml").read_text())["project"]["scripts"]
    module, _, function = scripts["build-dataset"].partition(":")
    code = f"import sys; from {module} import {function}; sys.exit({function}())"
    return [sys.executable, "-c", code]


def build(tree: Path, takes: list[Path], out: Path, *, no_cache: bool) -> None:
    cmd = [*build_command(tree), *map(str, takes), str(out), "--workers", "1", "--quiet"]
    if no_cache:
        cmd.append("--no-cache")
    env = os.environ | {"PYTHONPATH": str(tree)}
    run = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    if run.returncode > 1:  # 1: some take failed, which the comparison shows
        raise SystemExit(f"build-dataset in {tree} failed:\n{run.stderr[-2000:]}")


def without_volatile(value: object) -> object:
    if isinstance(value, dict):
        return {k: without_volatile(v) for k, v in value.items() if k not in VOLATILE}
    if isinstance(value, list):
        return [without_volatile(v) for v in value]
    if isinstance(value, float) and math.isnan(value):
        return "NaN"  # a missing value (a mocap take's video_fps) equals itself
    return value


def compare(ours: Path, theirs: Path, *, atol: float) -> list[tuple[str, str]]:
    """(file, what differs) for every file that is not the same in both datasets."""
    differences = []
    names = {p.relative_to(ours) for p in ours.rglob("*") if p.is_file()}
    names |= {p.relative_to(theirs) for p in theirs.rglob("*") if p.is_file()}
    for name in sorted(names):
        a, b = ours / name, theirs / name
        if not (a.is_file() and b.is_file()):
            differences.append(
                (str(name), "only in " + ("this tree" if a.is_file() else "--against"))
            )
        elif name.suffix == ".npz":
            with np.load(a) as x, np.load(b) as y:
                if set(x.files) != set(y.files):
                    differences.append((str(name), f"arrays {sorted(x.files)} ≠ {sorted(y.files)}"))
                    continue
                for key in x.files:
                    u, v = x[key], y[key]
                    same = u.shape == v.shape and (
                        np.array_equal(u, v)
                        if not np.issubdtype(u.dtype, np.number)
                        else np.allclose(u, v, rtol=0, atol=atol, equal_nan=True)
                    )
                    if not same:
                        differences.append((str(name), f"array {key} differs"))
        elif name.suffix in {".json", ".parquet"}:
            if without_volatile(records(a)) != without_volatile(records(b)):
                differences.append((str(name), "records differ"))
        elif name.name not in UNCOMPARED and content(a, ours) != content(b, theirs):
            differences.append((str(name), "content differs"))
    return differences


def content(path: Path, root: Path) -> bytes:
    """The file's bytes, with its dataset's own folder (the pages name it) written as OUT_DIR and
    the page cache's key (a checksum that covers the folder) left out."""
    text = path.read_bytes().replace(str(root).encode(), b"OUT_DIR")
    return re.sub(rb"page-key [0-9a-f]+", b"page-key", text)


def records(path: Path) -> object:
    if path.suffix == ".parquet":
        return pq.read_table(path).to_pylist()
    return json.loads(path.read_text())


def default_takes(quick: bool) -> list[Path]:
    samples = default_samples_dir()
    fetch_samples(samples)
    talking = samples / "talking"
    if quick:
        return [talking / "outdoor" / "sports2d_arctic.mp4"]
    return [talking, samples / "bvhtools" / "testBvhFiles" / "test2.bvh"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.partition("\n\n")[0])
    parser.add_argument("--against", default="HEAD", help="the commit to compare with")
    parser.add_argument(
        "--takes", nargs="+", type=Path, help="folders or files, each built into its own dataset"
    )
    parser.add_argument("--atol", type=float, default=1e-9)
    parser.add_argument("--no-cache", action="store_true", help="run the detector in both")
    parser.add_argument("--quick", action="store_true", help="one short clip against HEAD")
    args = parser.parse_args()
    takes = args.takes or default_takes(args.quick)
    with tempfile.TemporaryDirectory(prefix="same-outputs-") as tmp:
        other = Path(tmp) / "tree"
        subprocess.run(
            ["git", "-C", str(REPO), "worktree", "add", "--detach", "-q", str(other), args.against],
            check=True,
        )
        try:
            differences, files = [], 0
            for i, take in enumerate(takes):  # each input its own dataset: a folder or a file
                ours, theirs = Path(tmp) / f"ours{i}", Path(tmp) / f"theirs{i}"
                build(REPO, [take], ours, no_cache=args.no_cache)
                build(other, [take], theirs, no_cache=args.no_cache)
                found = compare(ours, theirs, atol=args.atol)
                differences += [(f"{take.name}: {name}", what) for name, what in found]
                files += sum(1 for p in ours.rglob("*") if p.is_file())
        finally:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(other)])
    table = Table(title=f"this checkout vs {args.against}: {files} files, atol {args.atol:g}")
    table.add_column("file")
    table.add_column("differs")
    for name, what in differences:
        table.add_row(name, what)
    if not differences:
        table.add_row("(all)", "same")
    Console().print(table)
    raise SystemExit(1 if differences else 0)


if __name__ == "__main__":
    main()
