"""How well the QC (gesturebank.qc) rejects corrupted takes and keeps clean ones, on real takes.

Real material: the sample media's real videos (`gesturebank fetch-samples`): the four 60 fps
cameras of the Pose2Sim demo (one person, 1.67 s; each muxed with real CMU ARCTIC speech by a
same-stem .wav beside it) and the 30 fps Sports2D demo clip (7.7 s, two people). They are built
with the real builder (`build_dataset`, default config: MediaPipe + BlazePose world lifter).

Clean variants (few real takes exist, so many honest variants are made from them):
1. windows of `--window` s every `--stride` s over each built take (`qc.corrupt.window`);
   overlapping windows are not independent — the table counts variants, not independent takes;
2. each window also mirrored left↔right (`qc.corrupt.mirror`: the real motion of a mirrored
   person), angles re-derived from the 3D joints as the builder does (`qc.corrupt.rederive`).
The clean pool keeps a window only when every upper-body keypoint is detected with confidence
≥ 0.5 in every frame, and leaves out the takes listed in `--defective`, on evidence outside the QC:
lab__cam02 (front view; its skeleton frames on the QC page show the detector exchanging the
arms) and outdoor__sports2d_arctic (two people; the builder's tracker reports 2 identity switches
of the main speaker). The QC verdicts on the whole real takes are printed too.

Corrupted variants: every clean variant × every corruption kind × strength (`qc.corrupt.corrupt`,
seeded by the variant's index), angles re-derived from the corrupted 3D joints. Each corrupted
variant is judged in a dataset made of the whole clean pool plus itself (a bad take among good
ones, which is what the dataset-relative checks assume); the clean pool is judged on its own.

Run: .venv/bin/python benchmarks/qc.py [--window 1.2] [--stride 0.05] [--out DIR]
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.qc.checks import QCConfig, verdicts
from gesturebank.qc.corrupt import corrupt, mirror, rederive, window
from gesturebank.qc.metrics import take_metrics

# (kind, strength) cells; units as in gesturebank/qc/corrupt.py
STRENGTHS = {
    "spikes": (1.0, 2.0, 4.0),  # jump size, shoulder widths, one per started second
    "jitter": (0.05, 0.1, 0.2),  # noise std, shoulder widths
    "frozen": (0.2, 0.4, 0.6),  # share of the take held
    "dropout": (0.3, 0.5, 0.8),  # share of the take missing
    "swap": (1, 2, 3),  # number of swapped segments (0.1–0.3 s each)
}


def build(out: Path) -> Path:
    """Build the real takes (see the module docstring) into `out`; returns `out`."""
    from gesturebank.config import Config
    from gesturebank.datasets.build import build_dataset
    from gesturebank.datasets.takes import discover_takes
    from gesturebank.samples import default_samples_dir, fetch_samples

    root = Path(default_samples_dir())
    fetch_samples(root)
    videos = out / "videos"
    (videos / "lab").mkdir(parents=True, exist_ok=True)
    (videos / "outdoor").mkdir(parents=True, exist_ok=True)
    speech = ("arctic_a0007", "arctic_a0009")
    for i in range(1, 5):
        src = root / "pose2sim" / "Demo_SinglePerson" / "videos" / f"cam0{i}.mp4"
        shutil.copy(src, videos / "lab" / src.name)
        shutil.copy(root / "speech" / f"{speech[i % 2]}.wav", videos / "lab" / f"cam0{i}.wav")
    shutil.copy(root / "talking" / "outdoor" / "sports2d_arctic.mp4", videos / "outdoor")
    build_dataset(discover_takes(videos), videos, out / "dataset", Config())
    return out / "dataset"


def variants(dataset: Path, win: float, stride: float, defective: set[str], config: QCConfig):
    """(clean variants [(name, arrays)], whole takes [(take_id, arrays)], excluded counts)."""
    from gesturebank.datasets import open as open_dataset

    ds = open_dataset(dataset)
    clean, whole, excluded = [], [], Counter()
    for record, arrays in ds:
        take_id = record["take_id"]
        whole.append((take_id, arrays))
        t = arrays["times"]
        for t0 in np.arange(t[0], t[-1] - win + 1e-9, stride):
            part = window(arrays, t0, t0 + win)
            m = take_metrics(part, min_confidence=config.min_confidence)
            if take_id in defective:
                excluded["listed as defective"] += 2
                continue
            if m["missing_keypoints_fraction"] > 0:
                excluded["keypoints not all detected"] += 2
                continue
            clean.append((f"{take_id}@{t0:.2f}", part))
            clean.append((f"{take_id}@{t0:.2f}/mirror", rederive(mirror(part))))
    return clean, whole, excluded


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--window", type=float, default=1.2, help="window length, s")
    ap.add_argument("--stride", type=float, default=0.05, help="window step, s")
    ap.add_argument("--out", type=Path, help="build folder (kept; default: a temporary one)")
    ap.add_argument("--defective", nargs="*", default=["lab__cam02", "outdoor__sports2d_arctic"])
    args = ap.parse_args()
    config = QCConfig()
    console = Console()

    tmp = None
    if args.out is None:
        tmp = tempfile.TemporaryDirectory()
        args.out = Path(tmp.name)
    dataset = build(args.out) if not (args.out / "dataset").is_dir() else args.out / "dataset"

    def measure(arrays: dict) -> dict[str, float]:
        return take_metrics(
            arrays,
            analysis_rate_hz=config.analysis_rate_hz,
            min_confidence=config.min_confidence,
            jitter_above_hz=config.jitter_above_hz,
        )

    clean, whole, excluded = variants(
        dataset, args.window, args.stride, set(args.defective), config
    )
    clean_m = {name: measure(a) for name, a in clean}

    # Whole real takes, judged together.
    table = Table(title="QC of the whole real takes (judged together)")
    table.add_column("take")
    table.add_column("verdict")
    table.add_column("reasons")
    whole_v = verdicts({tid: measure(a) for tid, a in whole}, config)
    for tid, (status, reasons) in whole_v.items():
        table.add_row(tid, status, "; ".join(reasons))
    console.print(table)
    console.print(
        f"clean pool: {len(clean)} variants ({len(clean) // 2} windows of {args.window} s every "
        f"{args.stride} s + their mirror images); excluded: {dict(excluded)}"
    )

    # Clean pool alone: false rejections.
    clean_v = verdicts(clean_m, config)
    rejected = [(n, r) for n, (s, r) in clean_v.items() if s == "rejected"]
    table = Table(title="Detection of corrupted variants and false rejection of clean ones")
    for col in ("variants", "kind", "strength", "n", "rejected", "rate", "most frequent reason"):
        table.add_column(col)

    def top(reason_lists: list[list[str]]) -> str:
        words = Counter(r.split(":")[0].split(" ")[0] for rs in reason_lists for r in rs)
        return ", ".join(f"{w} ({c})" for w, c in words.most_common(3))

    n_clean = len(clean_v)
    table.add_row(
        "clean",
        "—",
        "—",
        str(n_clean),
        str(len(rejected)),
        f"{len(rejected) / n_clean:.1%}",
        top([r for _, r in rejected]),
    )
    for kind, strengths in STRENGTHS.items():
        for strength in strengths:
            hits, reasons = 0, []
            for i, (name, arrays) in enumerate(clean):
                bad = rederive(corrupt(arrays, kind, strength, seed=i))
                key = f"{name}+{kind}"
                v = verdicts({**clean_m, key: measure(bad)}, config)[key]
                hits += v[0] == "rejected"
                reasons.append(v[1])
            table.add_row(
                "corrupted",
                kind,
                f"{strength:g}",
                str(n_clean),
                str(hits),
                f"{hits / n_clean:.1%}",
                top(reasons),
            )
    console.print(table)
    if rejected:
        console.print("falsely rejected clean variants:")
        for name, r in rejected:
            console.print(f"  {name}: {'; '.join(r)}")
    if tmp is not None:
        tmp.cleanup()


if __name__ == "__main__":
    main()
