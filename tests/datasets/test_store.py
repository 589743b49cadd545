"""The on-disk dataset: atomic per-take files, resumability, manifest, lazy reader."""

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

import gesturebank.datasets
from gesturebank.datasets import store
from gesturebank.errors import InputError
from gesturebank.fileio import atomic_open


def record(take_id: str, status: str = "accepted", digest: str = "d1", **kw) -> store.TakeRecord:
    return store.TakeRecord(
        take_id=take_id,
        subject=kw.pop("subject", "s1"),
        source=f"videos/{take_id}.mp4",
        qc_status=status,  # type: ignore[arg-type]
        config_digest=digest,
        **kw,
    )


def arrays(n: int = 50) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(n)
    return {"angles": rng.normal(size=(n, 11)).astype(np.float32), "audio": np.ones((n, 26))}


def test_built_means_same_config_and_data_present(tmp_path: Path) -> None:
    store.write_take(tmp_path, record("a"), arrays())
    assert store.is_built(tmp_path, "a", "d1")
    assert not store.is_built(tmp_path, "a", "d2")  # config changed → rebuild
    assert not store.is_built(tmp_path, "b", "d1")
    store.take_npz(tmp_path, "a").unlink()
    assert not store.is_built(tmp_path, "a", "d1")  # data lost → rebuild


def test_failed_take_has_no_data_and_is_retried(tmp_path: Path) -> None:
    store.write_take(tmp_path, record("a"), arrays())
    store.write_take(tmp_path, record("a", "failed", qc_reasons=("no person",)), None)
    assert not store.take_npz(tmp_path, "a").exists()  # no stale arrays from the older build
    assert not store.is_built(tmp_path, "a", "d1")
    assert store.read_record(tmp_path, "a").qc_reasons == ("no person",)


def test_corrupt_record_counts_as_not_built(tmp_path: Path) -> None:
    store.write_take(tmp_path, record("a"), arrays())
    store.take_json(tmp_path, "a").write_text("{truncated")
    assert store.read_record(tmp_path, "a") is None
    assert not store.is_built(tmp_path, "a", "d1")


def test_interrupted_write_leaves_nothing_under_the_final_name(tmp_path: Path) -> None:
    target = tmp_path / "takes" / "x.npz"
    with pytest.raises(KeyboardInterrupt), atomic_open(target) as f:
        f.write(b"half of it")
        raise KeyboardInterrupt
    assert not target.exists()
    assert list((tmp_path / "takes").iterdir()) == []  # the temporary file is gone too


def test_object_arrays_are_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="dtype object"):
        store.write_take(tmp_path, record("a"), {"x": np.array([{}], dtype=object)})


def test_manifest_and_reader(tmp_path: Path) -> None:
    store.write_take(tmp_path, record("a", metrics={"jerk": 1.5}, traits={"age": "30"}), arrays())
    store.write_take(tmp_path, record("b", "rejected", qc_reasons=("jerk 12× median",)), arrays(30))
    store.write_take(tmp_path, record("c", "failed", qc_reasons=("corrupt file",)), None)
    store.write_manifest(tmp_path)
    store.write_dataset_json(tmp_path, {"tool_version": "test"})

    table = pq.read_table(tmp_path / "manifest.parquet")  # plain pyarrow, no gesturebank
    assert table.column("take_id").to_pylist() == ["a", "b", "c"]
    assert table.column("qc_status").to_pylist() == ["accepted", "rejected", "failed"]
    assert table.column("qc_reasons").to_pylist()[1] == ["jerk 12× median"]
    assert dict(table.column("metrics").to_pylist()[0]) == {"jerk": 1.5}
    assert json.loads((tmp_path / "dataset.json").read_text())["schema_version"] == 1

    ds = gesturebank.datasets.open(tmp_path)
    assert len(ds) == 3
    assert ds.take_ids() == ["a"]
    assert ds.take_ids(None) == ["a", "b", "c"]
    assert ds.records()[0]["traits"] == {"age": "30"}
    np.testing.assert_array_equal(ds.load("a")["angles"], arrays()["angles"])
    assert [r["take_id"] for r, _ in ds] == ["a", "b"]  # failed takes have no arrays


def test_open_names_the_problem(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="dataset.json: not found"):
        gesturebank.datasets.open(tmp_path)
    (tmp_path / "dataset.json").write_text(json.dumps({"schema_version": 99}))
    with pytest.raises(InputError, match="schema_version 99"):
        gesturebank.datasets.open(tmp_path)
