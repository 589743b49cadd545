"""benchmarks/same_outputs.py's comparison finds what differs and nothing else: an array off by
more than the tolerance, a record, a page, a missing file; not the dataset's own folder or the
page cache's key."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "same_outputs.py"
spec = importlib.util.spec_from_file_location("same_outputs", SCRIPT)
assert spec and spec.loader
same_outputs = importlib.util.module_from_spec(spec)
spec.loader.exec_module(same_outputs)


def _dataset(root: Path, *, angle: float, take: str, page: str) -> Path:
    (root / "takes").mkdir(parents=True)
    np.savez(root / "takes" / "a.npz", angles=np.array([0.5, angle]), names=np.array(["x", "y"]))
    (root / "takes" / "a.json").write_text(
        json.dumps({"take": take, "fps": float("nan"), "built_at": str(root)})
    )
    (root / "index.html").write_text(f"<!-- page-key {abs(hash(root)):x} -->{root}: {page}")
    return root


def test_only_real_differences_are_reported(tmp_path: Path) -> None:
    ours = _dataset(tmp_path / "ours", angle=1.0, take="t", page="1 take")
    same = _dataset(tmp_path / "same", angle=1.0 + 1e-12, take="t", page="1 take")
    assert same_outputs.compare(ours, same, atol=1e-9) == []

    other = _dataset(tmp_path / "other", angle=1.0 + 1e-6, take="u", page="2 takes")
    (other / "extra.md").write_text("")
    assert sorted(same_outputs.compare(ours, other, atol=1e-9)) == [
        ("extra.md", "only in --against"),
        ("index.html", "content differs"),
        ("takes/a.json", "records differ"),
        ("takes/a.npz", "array angles differs"),
    ]
