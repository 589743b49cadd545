"""How well the QC (gesturebank.qc) rejects corrupted clips and keeps clean ones, on real clips.

Real material: the talking demos of `gesturebank fetch-samples` and the footage of
`gesturebank.footage` (a 60 s take, 60 and 30 fps copies, waist-up, a cut, a crossing, low
resolution, two people), built with the real builder and the default config.

Clean variants (on evidence outside the QC), from takes not listed in `--defective`:
1. whole clips in which the head and both arms were seen in at least 95 % of the frames — the
   long ones included (the 60 s take gives clips of up to a minute);
2. windows of `--window` s every `--stride` s over them in which they were seen in every frame
   (`testing.corrupt.window`; overlapping windows are not independent: the table counts variants,
   not independent clips);
3. each window also mirrored left↔right (`testing.corrupt.mirror`: the real motion of a mirrored
   person), angles re-derived as the builder does (`testing.corrupt.rederive`).

Corrupted variants: every clean variant × every corruption kind × strength (`testing.corrupt`,
seeded by the variant's index), angles re-derived. They act on what the repair left, as a glitch
that survived it would. Each corrupted variant is judged in a dataset made of the whole clean
pool plus itself (a bad clip among good ones, as the dataset-relative checks assume); the clean
pool is judged on its own. A dropout shorter than the QC's unseen-share limits is not a reason
to reject: it counts as caught when its frames are masked (no angle invented there).

    .venv/bin/python benchmarks/qc.py [--quick] [--window 3] [--stride 1] [--out DIR]
"""

from __future__ import annotations

import argparse
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.clip import Clip
from gesturebank.config import Config, QCConfig
from gesturebank.qc.checks import verdicts
from gesturebank.qc.clip_metrics import ClipMetrics
from gesturebank.qc.metrics import clip_metrics
from gesturebank.robot import pepper
from gesturebank.skeletons import COCO17
from gesturebank.testing.corrupt import corrupt, mirror, rederive, window

# (kind, strength) cells; units as in gesturebank/testing/corrupt.py
STRENGTHS = {
    "spikes": (1.0, 2.0, 4.0),  # jump size, shoulder widths, one per started second
    "jitter": (0.05, 0.1, 0.2),  # noise std, shoulder widths
    "frozen": (0.2, 0.4, 0.6),  # share of the clip held
    "dropout": (0.3, 0.5, 0.8),  # share of the clip unseen
    "swap": (1, 2, 3),  # number of swapped segments (0.1–0.3 s each)
}
# Seen in every frame for a clip to be clean: the head and both arms.
_HEAD = ("nose", "left_eye", "right_eye", "left_shoulder", "right_shoulder")
_ARMS = ("left_elbow", "right_elbow", "left_wrist", "right_wrist")
_SEEN = [COCO17.index[j] for j in (*_HEAD, *_ARMS)]
MIN_SEEN = 0.95  # share of a whole clean clip's frames with the head and both arms seen


def build(root: Path, quick: bool) -> Path:
    """The real dataset (see the module docstring) in `root/dataset`; returns it."""
    from gesturebank.app.build import build_dataset
    from gesturebank.datasets.takes import discover_takes
    from gesturebank.footage import make_footage
    from gesturebank.samples import default_samples_dir, fetch_samples

    samples = default_samples_dir()
    fetch_samples(samples)
    scale = 0.5 if quick else 1.0
    cache = samples.parent / "footage" / f"scale{scale:g}"
    made = make_footage(samples, cache, time_scale=scale, names=("fps30",) if quick else None)
    videos = root / "videos"
    for name, path in made.items():
        if quick and name != "fps30":
            continue
        (videos / name).mkdir(parents=True, exist_ok=True)
        (videos / name / path.name).symlink_to(path)
    for path in sorted((samples / "talking").rglob("*.mp4")):
        (videos / "talking").mkdir(parents=True, exist_ok=True)
        (videos / "talking" / path.name).symlink_to(path)
    out = root / "dataset"
    build_dataset(discover_takes(videos), videos_dir=videos, out=out, config=Config())
    return out


def clean_variants(
    dataset: Path, win: float, stride: float, defective: set[str]
) -> tuple[list[tuple[str, Clip]], Counter[str]]:
    from gesturebank.datasets import open as open_dataset

    ds = open_dataset(dataset)
    clean: list[tuple[str, Clip]] = []
    excluded: Counter[str] = Counter()
    for row in ds.clips(None):
        clip = ds.load(row.clip.clip_id)
        if row.take.take_id in defective:
            excluded["listed as defective"] += 1
            continue
        if clip.valid[:, _SEEN].all(axis=1).mean() < MIN_SEEN:
            excluded[f"head or an arm unseen in > {1 - MIN_SEEN:.0%} of frames"] += 1
            continue
        clean.append((row.clip.clip_id, clip))
        for t0 in np.arange(0.0, clip.times[-1] - win + 1e-9, stride):
            part = window(clip, t0, t1=t0 + win)
            if not part.valid[:, _SEEN].all():
                excluded["windows: head or an arm unseen somewhere"] += 1
                continue
            clean.append((f"{row.clip.clip_id}@{t0:.1f}", part))
            clean.append((f"{row.clip.clip_id}@{t0:.1f}/mirror", rederive(mirror(part))))
    return clean, excluded


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="two short takes, few windows")
    ap.add_argument("--window", type=float, default=3.0, help="window length, s")
    ap.add_argument("--stride", type=float, default=1.0, help="window step, s")
    ap.add_argument("--out", type=Path, help="build folder (kept; default: a temporary one)")
    ap.add_argument(
        "--defective",
        nargs="*",
        default=["talking__cam03_arctic"],
        help="takes left out of the clean pool (cam03 sees the speaker's back)",
    )
    args = ap.parse_args()
    if args.quick:
        args.stride = max(args.stride, 2.0)
    qc = QCConfig()
    profile = pepper.load_profile()
    console = Console(width=140)
    tmp = None
    if args.out is None:
        tmp = tempfile.TemporaryDirectory()
        args.out = Path(tmp.name)
    dataset = args.out / "dataset"
    if not dataset.is_dir():
        build(args.out, args.quick)

    def measure(clip: Clip) -> ClipMetrics:
        return clip_metrics(clip, profile=profile, qc=qc)

    clean, excluded = clean_variants(dataset, args.window, args.stride, set(args.defective))
    clean_m = {name: measure(c) for name, c in clean}
    longest = max((c.duration_s for _, c in clean), default=0.0)
    console.print(
        f"clean pool: {len(clean)} variants (whole clips up to {longest:.0f} s, windows of "
        f"{args.window} s every {args.stride} s and their mirror images); excluded clips: "
        f"{dict(excluded)}"
    )
    clean_v = verdicts(clean_m, qc)
    rejected = [(n, r) for n, (s, r) in clean_v.items() if s == "rejected"]
    table = Table(title="Detection of corrupted variants and false rejection of clean ones")
    for col in ("variants", "kind", "strength", "n", "caught", "rate", "most frequent reason"):
        table.add_column(col)

    def top(reason_lists: list[list[str]]) -> str:
        words = Counter(r.split(":")[0].split(" ")[0] for rs in reason_lists for r in rs)
        return ", ".join(f"{w} ({c})" for w, c in words.most_common(3))

    n = len(clean_v)
    table.add_row(
        "clean",
        "—",
        "—",
        str(n),
        str(len(rejected)),
        f"{len(rejected) / max(n, 1):.1%}",
        top([r for _, r in rejected]),
    )
    caught_all = total = 0
    for kind, strengths in STRENGTHS.items():
        for strength in strengths:
            hits, reasons = 0, []
            for i, (name, clip) in enumerate(clean):
                bad = rederive(corrupt(clip, kind, strength=strength, seed=i))
                key = f"{name}+{kind}"
                status, why = verdicts({**clean_m, key: measure(bad)}, qc)[key]
                masked = (
                    kind == "dropout"
                    and not (bad.mask & ~clip.mask).any()
                    and ((~bad.mask).mean() >= 0.9 * strength)
                )
                hits += status == "rejected" or masked
                reasons.append(why or (["masked"] if masked else []))
            caught_all += hits
            total += len(clean)
            table.add_row(
                "corrupted",
                kind,
                f"{strength:g}",
                str(len(clean)),
                str(hits),
                f"{hits / max(len(clean), 1):.1%}",
                top(reasons),
            )
    console.print(table)
    console.print(
        f"overall: corrupted caught {caught_all / max(total, 1):.1%} (target ≥ 95 %), clean "
        f"rejected {len(rejected) / max(n, 1):.1%} (target ≤ 5 %)"
    )
    if rejected:
        console.print("falsely rejected clean variants:")
        for name, r in rejected[:20]:
            console.print(f"  {name}: {'; '.join(r)}", highlight=False)
    if tmp is not None:
        tmp.cleanup()


if __name__ == "__main__":
    main()
