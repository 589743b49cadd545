"""benchmarks/same_outputs.py's comparison finds what differs and nothing else: an array off by
more than the tolerance, a record, a page, a missing file; not the dataset's own folder or the
page cache's key."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

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


def test_a_digest_moves_with_a_value_and_not_with_noise(tmp_path: Path) -> None:
    ours = same_outputs.digests(_dataset(tmp_path / "ours", angle=1.0, take="t", page="p"))
    noise = same_outputs.digests(
        _dataset(tmp_path / "noise", angle=1.0 + 1e-13, take="t", page="q")
    )
    moved = same_outputs.digests(_dataset(tmp_path / "moved", angle=1.0 + 1e-6, take="u", page="p"))
    assert sorted(ours) == ["takes/a.json", "takes/a.npz:angles", "takes/a.npz:names"]
    assert same_outputs.digest_differences(noise, ours) == []
    assert same_outputs.digest_differences(moved, ours) == ["takes/a.json", "takes/a.npz:angles"]
    del moved["takes/a.npz:names"]
    assert "takes/a.npz:names" in same_outputs.digest_differences(moved, ours)


def test_a_config_of_the_older_layout_compares_by_its_values(tmp_path: Path) -> None:
    from gesturebank.config import Config

    new = Config().to_json_dict()
    old = {k: v for k, v in new.items() if k not in ("lifter", "detector")}
    old["lifter"] = {"name": new["lifter"]["name"]}
    old["geometric"] = new["lifter"]["geometric"]  # the release before's top-level table
    old["detector"] = {"name": "blazepose", "max_people": 4}
    for key in ("fitted", "resolved", "learned", "multiview"):
        old[key] = new["lifter"][key]
    assert same_outputs.without_volatile({"config": old}) == same_outputs.without_volatile(
        {"config": new}
    )
    old["detector"]["max_people"] = 3
    assert same_outputs.without_volatile({"config": old}) != same_outputs.without_volatile(
        {"config": new}
    )


@pytest.mark.media
def test_the_talking_demo_builds_to_its_stored_digests(demo_dataset: Path) -> None:
    """The quick form of the same-outputs check: the demo dataset's arrays and records against
    tests/data/same_outputs_demo.json. A change meant to change outputs writes it again
    (`benchmarks/same_outputs.py --write-digests`, module docstring)."""
    stored = json.loads(same_outputs.DIGESTS.read_text())
    found = same_outputs.digests(demo_dataset)
    assert same_outputs.digest_differences(found, stored) == []


def test_a_missing_value_in_a_parquet_map_equals_itself() -> None:
    metrics = {"metrics": [("depth_confidence", 1.0), ("expected_hand_error_cm", float("nan"))]}
    again = {"metrics": [("depth_confidence", 1.0), ("expected_hand_error_cm", float("nan"))]}
    assert same_outputs.without_volatile(metrics) == same_outputs.without_volatile(again)
    again["metrics"][0] = ("depth_confidence", 0.5)
    assert same_outputs.without_volatile(metrics) != same_outputs.without_volatile(again)
