"""Same outputs: build the same takes with this checkout and with another commit, and compare.

A refactor that should change nothing (issue 34's house step) is checked here: every array of
every clip equal within --atol (1e-9); every JSON and Parquet record equal once the fields that
name a time or a place (build times, durations, the output folder) are left out; every other
file (the QC pages, the dataset card, previews) byte for byte, its folder's name aside.

    .venv/bin/python benchmarks/same_outputs.py --against house-base
    .venv/bin/python benchmarks/same_outputs.py --against HEAD~3 --takes DIR_OR_FILE ...
    .venv/bin/python benchmarks/same_outputs.py --write-digests DATASET

The other commit is checked out into a temporary git worktree and run with this interpreter
(PYTHONPATH=that tree), each build with the default config and one worker; detections come from
the detection cache, keyed by the video's checksum and the detector's settings (pass
--no-cache to run the detector in both). The takes default to the talking demo (`make demo`'s),
a motion-capture sample and a multi-camera take (Pose2Sim's single-person demo, clips of 1 s
and more: it lasts 1.7 s); then every model is trained for 2 epochs on the talking demo's
dataset (subject-dependent, its `lab` subject) by both trees (`--no-train`: not) and the model
folders are compared the same way. The build writes the QC dashboard, compared with the rest.
--quick builds the outdoor demo clip against HEAD.

The quick form in the test suite (`tests/test_same_outputs.py`) needs no second tree: it
compares the talking demo's dataset with the digests stored in
tests/data/same_outputs_demo.json (`digests`: every array's shape, NaN count and sums, every
record's canonical text, floats to 9 significant digits). A change meant to change outputs
writes them again: `benchmarks/same_outputs.py --write-digests DATASET` on a fresh
`build-dataset <samples>/talking DATASET`.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
from rich.console import Console
from rich.table import Table

from gesturebank.config import Config
from gesturebank.samples import default_samples_dir, fetch_samples
from gesturebank.train.eval.fgd import FGD_DIR

REPO = Path(__file__).resolve().parents[1]
DIGESTS = REPO / "tests" / "data" / "same_outputs_demo.json"
MULTI_CAMERA = "pose2sim/Demo_SinglePerson"  # calibrated 4-camera take of the samples
SIGNIFICANT = 9  # digits of a float kept in a digest
TRAIN_SUBJECT = "lab"  # the talking demo's subject the models are trained on
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
    "dataset",  # the dataset folder a model was trained from
}
# Digests of the config, which a new layout of the same values changes; the config itself is
# compared (`resolved`).
RELAID = {"config_digest"}
# Left out of the stored digests too: the inputs (the config, with every key a branch adds; the
# samples' folder, which is the machine's), the version, and the preview frames' times, which
# differ between a build that detects and one that reads cached detections (a frame or two).
INPUTS = {"config", "videos_dir", "tool_version", "preview_times"}


def build_command(tree: Path) -> list[str]:
    """The interpreter call that runs `tree`'s own build-dataset entry point."""
    return tree_command(tree, "build-dataset")


def train(tree: Path, dataset: Path, model: str, out: Path) -> str:
    """`gesturebank train DATASET --model MODEL --epochs 2` with `tree` on one subject of the
    talking demo (it has two: too few for subject-independent folds); "" or its error."""
    cmd = [*tree_command(tree, "gesturebank"), "train", str(dataset), "--model", model]
    cmd += ["--variant", "sd", "--subject", TRAIN_SUBJECT, "--epochs", "2", "--out", str(out)]
    env = os.environ | {"PYTHONPATH": str(tree)}
    run = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    return "" if run.returncode == 0 else (run.stderr.strip().splitlines() or ["failed"])[-1]


def _rounded(value: object) -> object:
    """`value` with every float to SIGNIFICANT digits and NaN as text (a digest's form)."""
    if isinstance(value, dict):
        return {str(k): _rounded(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_rounded(v) for v in value]
    if isinstance(value, float):
        return "NaN" if math.isnan(value) else float(f"{value:.{SIGNIFICANT}g}")
    return value


def _without_inputs(value: object) -> object:
    if isinstance(value, dict):
        return {k: _without_inputs(v) for k, v in value.items() if k not in INPUTS}
    if isinstance(value, list):
        return [_without_inputs(v) for v in value]
    return value


def digests(dataset: Path) -> dict[str, object]:
    """file[:array] → its digest, for every array (.npz: shape, NaN count, sum and sum of |x|)
    and every record (.json, .parquet: sha256 of its canonical JSON without the volatile fields
    and the INPUTS) of `dataset`. Text, small, and it moves when a value moves by more than ~1e-9
    relative."""
    out: dict[str, object] = {}
    for path in sorted(p for p in dataset.rglob("*") if p.is_file()):
        name = str(path.relative_to(dataset))
        if path.relative_to(dataset).parts[0] == FGD_DIR:  # evaluate's cache, not the build's
            continue
        if path.suffix == ".npz":
            with np.load(path) as arrays:
                for key in sorted(arrays.files):
                    a = arrays[key]
                    if not np.issubdtype(a.dtype, np.number):
                        text = json.dumps(a.tolist(), default=str)
                        out[f"{name}:{key}"] = hashlib.sha256(text.encode()).hexdigest()[:16]
                        continue
                    x = a.astype(np.float64)
                    sums = [float(np.nansum(x)), float(np.nansum(np.abs(x)))]
                    out[f"{name}:{key}"] = _rounded([list(a.shape), int(np.isnan(x).sum()), *sums])
        elif path.suffix in {".json", ".parquet"}:
            text = json.dumps(
                _rounded(_without_inputs(without_volatile(records(path)))),
                sort_keys=True,
                default=str,
            ).replace(str(dataset), "OUT_DIR")
            out[name] = hashlib.sha256(text.encode()).hexdigest()[:16]
    return out


def digest_differences(found: dict[str, object], stored: dict[str, object]) -> list[str]:
    """The names whose digest differs, or that only one side has."""
    return sorted(k for k in found.keys() | stored.keys() if found.get(k) != stored.get(k))


def tree_command(tree: Path, script: str) -> list[str]:
    """The interpreter call that runs `tree`'s own console script `script`."""
    scripts = tomllib.loads((tree / "pyproject.toml").read_text())["project"]["scripts"]
    module, _, function = scripts[script].partition(":")
    code = f"import sys; from {module} import {function}; sys.exit({function}())"
    return [sys.executable, "-c", code]


def build(
    tree: Path, takes: list[Path], out: Path, *, no_cache: bool, extra: tuple[str, ...] = ()
) -> None:
    cmd = [*build_command(tree), *map(str, takes), str(out), "--workers", "1", "--quiet"]
    cmd += list(extra)
    if no_cache:
        cmd.append("--no-cache")
    env = os.environ | {"PYTHONPATH": str(tree)}
    run = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    if run.returncode > 1:  # 1: some take failed, which the comparison shows
        raise SystemExit(f"build-dataset in {tree} failed:\n{run.stderr[-2000:]}")


def without_volatile(value: object) -> object:
    if isinstance(value, dict):
        return {
            k: resolved(v) if k == "config" else without_volatile(v)
            for k, v in value.items()
            if k not in VOLATILE | RELAID
        }
    if isinstance(value, list | tuple):  # a Parquet map column: a list of (key, value) tuples
        return [without_volatile(v) for v in value]
    if isinstance(value, float) and math.isnan(value):
        return "NaN"  # a missing value (a mocap take's video_fps) equals itself
    return value


def resolved(config: object) -> object:
    """A stored resolved config as this tree's `Config` reads and writes it, so a config written
    in an older layout (read with its deprecation warnings) compares by its values."""
    if not isinstance(config, dict):
        return config
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        try:
            return Config.model_validate(config).to_json_dict()
        except ValueError:  # not a whole Config (a section, a model's): as it is
            return without_volatile(config)


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
    text = re.sub(rb"config digest `[0-9a-f]+`", b"config digest", text)  # RELAID, in a card
    return re.sub(rb"page-key [0-9a-f]+", b"page-key", text)


def records(path: Path) -> object:
    if path.suffix == ".parquet":
        return pq.read_table(path).to_pylist()
    return json.loads(path.read_text())


def default_takes(quick: bool, tmp: Path) -> list[tuple[Path, tuple[str, ...]]]:
    """(input, build-dataset's extra options) of each dataset to build."""
    samples = default_samples_dir()
    fetch_samples(samples)
    talking = samples / "talking"
    if quick:
        return [(talking / "outdoor" / "sports2d_arctic.mp4", ())]
    rig = tmp / "rig"  # a folder holding the calibrated take: a multi-camera take
    rig.mkdir()
    (rig / "lab-4cams").symlink_to(samples / MULTI_CAMERA)
    return [
        (talking, ()),
        (samples / "bvhtools" / "testBvhFiles" / "test2.bvh", ()),
        (rig, ("--set", "clips.min_s=1.0")),
    ]


def models(tree: Path) -> list[str]:
    """The model names `tree` registers."""
    code = "from gesturebank.train.registry import MODELS; print(' '.join(MODELS.names()))"
    env = os.environ | {"PYTHONPATH": str(tree)}
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    return run.stdout.split()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.partition("\n\n")[0])
    parser.add_argument("--against", default="HEAD", help="the commit to compare with")
    parser.add_argument(
        "--takes", nargs="+", type=Path, help="folders or files, each built into its own dataset"
    )
    parser.add_argument("--atol", type=float, default=1e-9)
    parser.add_argument("--no-cache", action="store_true", help="run the detector in both")
    parser.add_argument("--quick", action="store_true", help="one short clip against HEAD")
    parser.add_argument("--no-train", action="store_true", help="compare the builds only")
    parser.add_argument(
        "--write-digests", type=Path, metavar="DATASET", help=f"write {DIGESTS.name} and stop"
    )
    args = parser.parse_args()
    if args.write_digests:
        DIGESTS.parent.mkdir(parents=True, exist_ok=True)
        DIGESTS.write_text(json.dumps(digests(args.write_digests), indent=1, sort_keys=True))
        print(f"{DIGESTS}: {len(json.loads(DIGESTS.read_text()))} digests")
        return
    with tempfile.TemporaryDirectory(prefix="same-outputs-") as tmp:
        takes = (
            [(t, ()) for t in args.takes] if args.takes else default_takes(args.quick, Path(tmp))
        )
        other = Path(tmp) / "tree"
        subprocess.run(
            ["git", "-C", str(REPO), "worktree", "add", "--detach", "-q", str(other), args.against],
            check=True,
        )
        try:
            differences, files = [], 0
            for i, (take, extra) in enumerate(takes):  # each input its own dataset
                ours, theirs = Path(tmp) / f"ours{i}", Path(tmp) / f"theirs{i}"
                build(REPO, [take], ours, no_cache=args.no_cache, extra=extra)
                build(other, [take], theirs, no_cache=args.no_cache, extra=extra)
                found = compare(ours, theirs, atol=args.atol)
                differences += [(f"{take.name}: {name}", what) for name, what in found]
                files += sum(1 for p in ours.rglob("*") if p.is_file())
            if not (args.quick or args.no_train or args.takes):  # every model, 2 epochs
                for model in sorted(set(models(REPO)) | set(models(other))):
                    mine, its = Path(tmp) / f"model-ours-{model}", Path(tmp) / f"model-{model}"
                    failed = (train(REPO, Path(tmp) / "ours0", model, mine),
                              train(other, Path(tmp) / "theirs0", model, its))  # fmt: skip
                    if any(failed):
                        differences.append((f"train {model}", " / ".join(failed)))
                        continue
                    found = compare(mine, its, atol=args.atol)
                    differences += [(f"train {model}: {name}", what) for name, what in found]
                    files += sum(1 for p in mine.rglob("*") if p.is_file())
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
