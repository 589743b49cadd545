"""Train/validation/test splits (dissertation Table 4.4), over the dataset's clips.

Subject-independent (SI): k-fold over subjects. Subjects are shuffled once (seeded) and cut into
k groups; fold i tests on group i, validates on group i+1 and trains on the rest — with 19
subjects and k = 10 that is the dissertation's 15 / 2 / 2 subjects per fold. Each part lists
the clips of its subjects.

Subject-dependent (SD): within each subject, their clips in time order (take, then start in the
take) are cut by time into the first 70 %, the next 15 % and the last 15 %, as
(clip_id, start_frame, end_frame) segments.

Dyadic (seed 004 §5, §7): clips shuffled (seeded) and cut into `dyadic_fractions` of the clips
(85 / 10 / 5 %), but a clip and its partner (`datasets.partners`) always land in the same part,
so a speaker's test clip never has its listener in training or validation (the dyadic leakage
constraint). The unit shuffled is a group: the clips linked by partnership, a pair in a dyad.

Dropped spans and failed takes never enter a split; clips the QC rejected only when asked.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np

from gesturebank.config import SplitsConfig
from gesturebank.errors import InputError
from gesturebank.fileio import write_bytes_atomic

SPLITS_DIR = "splits"
PARTS = ("train", "val", "test")


def _usable(records: Sequence[Mapping[str, Any]], include_rejected: bool) -> list[Mapping]:
    """Manifest rows of the clips a split may use, in time order."""
    ok = {"accepted", "rejected"} if include_rejected else {"accepted"}
    rows = [
        r
        for r in records
        if r.get("kind", "clip") == "clip" and r["qc_status"] in ok and int(r["n_frames"]) > 0
    ]
    return sorted(rows, key=lambda r: (r["take_id"], float(r["start_s"])))


def subject_independent(
    records: Sequence[Mapping[str, Any]], *, config: SplitsConfig
) -> list[dict[str, Any]]:
    """SI folds (`config.folds`, shuffled by `config.seed`): each a dict of clip ids and
    subjects per part. Needs ≥ 3 subjects."""
    folds, seed = config.folds, config.seed
    usable = _usable(records, config.include_rejected)
    subjects = sorted({r["subject"] for r in usable})
    if len(subjects) < 3:
        found = ", ".join(subjects) if subjects else "none with usable clips"
        raise InputError(
            f"subject-independent splits need at least 3 subjects, the dataset has "
            f"{len(subjects)} ({found}); name each take's subject in subjects.csv (columns "
            "take,subject) or with build.subject_pattern"
        )
    k = min(folds, len(subjects))
    order = [subjects[i] for i in np.random.default_rng(seed).permutation(len(subjects))]
    groups = [list(g) for g in np.array_split(np.array(order, dtype=object), k)]
    result = []
    for i in range(k):
        parts = {"test": set(groups[i]), "val": set(groups[(i + 1) % k])}
        parts["train"] = set(subjects) - parts["test"] - parts["val"]
        result.append(
            {
                "variant": "si",
                "fold": i,
                "subjects": {p: sorted(parts[p]) for p in PARTS},
                **{p: [r["clip_id"] for r in usable if r["subject"] in parts[p]] for p in PARTS},
            }
        )
    return result


def subject_dependent(
    records: Sequence[Mapping[str, Any]], *, config: SplitsConfig
) -> dict[str, Any]:
    """SD split: per subject, (clip_id, start, end) frame segments for train, val and test
    (`config.sd_fractions` of its frames)."""
    fractions = config.sd_fractions
    if len(fractions) != 3 or not np.isclose(sum(fractions), 1.0) or min(fractions) < 0:
        raise InputError(
            f"split fractions must be three non-negative numbers summing to 1, got {fractions}"
        )
    usable = _usable(records, config.include_rejected)
    per_subject: dict[str, dict[str, list[list[Any]]]] = {}
    for subject in sorted({r["subject"] for r in usable}):
        clips = [r for r in usable if r["subject"] == subject]
        lengths = np.array([int(r["n_frames"]) for r in clips])
        starts = np.concatenate([[0], np.cumsum(lengths)])  # clip j spans starts[j]:starts[j+1]
        total = int(starts[-1])
        cuts = [0, round(total * fractions[0]), round(total * (fractions[0] + fractions[1])), total]
        parts: dict[str, list[list[Any]]] = {p: [] for p in PARTS}
        for p, (lo, hi) in zip(PARTS, pairwise(cuts), strict=True):
            for r, a, b in zip(clips, starts[:-1], starts[1:], strict=True):
                s, e = max(lo, int(a)), min(hi, int(b))
                if e > s:
                    parts[p].append([r["clip_id"], s - int(a), e - int(a)])
        per_subject[subject] = parts
    return {"variant": "sd", "fractions": list(fractions), "subjects": per_subject}


def partner_groups(records: Sequence[Mapping[str, Any]]) -> list[list[str]]:
    """The clips of `records` grouped by partnership (connected: a clip, its partner, the
    partner's partner, ...), each group in the records' order; a clip without partner alone.
    A partner outside `records` (e.g. rejected) is ignored."""
    ids = [r["clip_id"] for r in records]
    parent = {i: i for i in ids}

    def root(i: str) -> str:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for r in records:
        partner = r.get("partner_clip_id") or ""
        if partner in parent:
            parent[root(r["clip_id"])] = root(partner)
    groups: dict[str, list[str]] = {}
    for i in ids:
        groups.setdefault(root(i), []).append(i)
    return list(groups.values())


def dyadic(records: Sequence[Mapping[str, Any]], *, config: SplitsConfig) -> dict[str, Any]:
    """Dyadic split: the clip ids of train, val and test (`config.dyadic_fractions` of the
    clips), partner groups shuffled by `config.seed` and never divided. A group goes to the part
    its first clip falls in, counting clips in the shuffled order."""
    usable = _usable(records, config.include_rejected)
    groups = partner_groups(usable)
    order = [groups[i] for i in np.random.default_rng(config.seed).permutation(len(groups))]
    total = sum(len(g) for g in order)
    f = config.dyadic_fractions
    cuts = (round(total * f[0]), round(total * (f[0] + f[1])))
    parts: dict[str, list[str]] = {p: [] for p in PARTS}
    before = 0
    for group in order:
        part = "train" if before < cuts[0] else "val" if before < cuts[1] else "test"
        parts[part] += group
        before += len(group)
    paired = sum(1 for r in usable if r.get("partner_clip_id"))
    return {"variant": "dyadic", "fractions": list(f), "paired_clips": paired, **parts}


def write_splits(
    out: Path, *, records: Sequence[Mapping[str, Any]], config: SplitsConfig | None = None
) -> list[str]:
    """Write splits/si_fold_XX.json (when there are ≥ 3 subjects), splits/sd.json and
    splits/dyadic.json (when clips have partners).

    Returns notes on what could not be written (e.g. too few subjects for SI)."""
    c = config or SplitsConfig()
    folder = Path(out) / SPLITS_DIR
    notes = []
    for old in folder.glob("si_fold_*.json"):
        old.unlink()  # a rebuild with fewer subjects must not keep stale folds
    try:
        folds = subject_independent(records, config=c)
        for fold in folds:
            path = folder / f"si_fold_{fold['fold']:02d}.json"
            write_bytes_atomic(path, json.dumps(fold, indent=1).encode())
    except InputError as exc:
        notes.append(f"no subject-independent splits: {exc}")
    sd = subject_dependent(records, config=c)
    write_bytes_atomic(folder / "sd.json", json.dumps(sd, indent=1).encode())
    (folder / "dyadic.json").unlink(missing_ok=True)
    split = dyadic(records, config=c)
    if split["paired_clips"]:
        write_bytes_atomic(folder / "dyadic.json", json.dumps(split, indent=1).encode())
    return notes
