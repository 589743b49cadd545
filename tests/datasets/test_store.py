"""The on-disk dataset (schema 5): atomic per-take folders of clips, resumability, manifest,
dataset.json, the lazy reader — and what a user's script sees without gesturebank."""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

import gesturebank.datasets
from gesturebank.clip import HEAD_SOURCES, Clip
from gesturebank.config import Config
from gesturebank.datasets import store
from gesturebank.datasets.refresh import refresh
from gesturebank.errors import InputError
from gesturebank.testing.clips import synthetic_clip, write_dataset


def clip(take: str, k: int = 0, seconds: float = 3.5, seed: int = 0) -> Clip:
    return synthetic_clip(seconds=seconds, seed=seed, clip_id=f"{take}__c{k:03d}")


def record(take: str, clips: list[Clip], digest: str = "d1", **kw) -> store.TakeRecord:
    rows = [
        store.ClipRecord(
            c.clip_id, "clip", 10.0 * i, 10.0 * i + c.duration_s, "accepted", parts="head+arms"
        )
        for i, c in enumerate(clips)
    ]
    rows += kw.pop("spans", [])
    return store.TakeRecord(
        take, kw.pop("subject", "s1"), f"{take}.mp4", digest, clips=tuple(rows), **kw
    )


def test_built_means_same_config_and_every_clip_present(tmp_path: Path) -> None:
    clips = [clip("a"), clip("a", 1, seed=1)]
    store.write_take(tmp_path, record=record("a", clips), clips=clips)
    assert store.is_built(tmp_path, take_id="a", config_digest="d1")
    assert not store.is_built(tmp_path, take_id="a", config_digest="d2")  # config changed → rebuild
    assert not store.is_built(tmp_path, take_id="b", config_digest="d1")
    store.clip_npz(tmp_path, take_id="a", clip_id="a__c001").unlink()
    assert not store.is_built(tmp_path, take_id="a", config_digest="d1")  # data lost → rebuild


def test_rebuild_replaces_the_take_folder_and_failure_leaves_no_arrays(tmp_path: Path) -> None:
    clips = [clip("a"), clip("a", 1)]
    store.write_take(tmp_path, record=record("a", clips), clips=clips)
    fewer = [clip("a", seed=2)]
    store.write_take(tmp_path, record=record("a", fewer), clips=fewer)
    assert sorted(p.name for p in store.take_dir(tmp_path, "a").iterdir()) == ["a__c000.npz"]
    failed = store.TakeRecord("a", "s1", "a.mp4", "d1", failed="a.mp4: no person")
    store.write_take(tmp_path, record=failed)
    assert list(store.take_dir(tmp_path, "a").iterdir()) == []  # no stale clips
    assert not store.is_built(tmp_path, take_id="a", config_digest="d1")  # failed takes are retried
    assert store.read_record(tmp_path, "a").failed == "a.mp4: no person"


def test_record_must_match_the_clips_written(tmp_path: Path) -> None:
    clips = [clip("a"), clip("a", 1)]
    with pytest.raises(ValueError, match="differ"):
        store.write_take(tmp_path, record=record("a", clips), clips=clips[:1])


def test_recorded_parts_must_be_the_masks(tmp_path: Path) -> None:
    """The invariant where a take is written: the manifest's `parts` name the parts the clip's
    mask has; a clip whose arms are masked whole is "head"."""
    whole = clip("a")
    with pytest.raises(ValueError, match="recorded parts 'head', its mask has 'head\\+arms'"):
        good = record("a", [whole])
        said = replace(good.clips[0], parts="head")
        store.write_take(tmp_path, record=replace(good, clips=(said,)), clips=[whole])
    arms = np.zeros(11, bool)
    arms[2:10] = True  # the eight arm joints
    head_only = replace(
        whole,
        mask=whole.mask & ~arms,
        angles=np.where(arms, np.nan, whole.angles).astype(np.float32),
        angles01=np.where(arms, np.nan, whole.angles01).astype(np.float32),
    )
    rec = record("a", [head_only])
    rec = replace(rec, clips=(replace(rec.clips[0], parts="head"),))
    store.write_take(tmp_path, record=rec, clips=[head_only])
    assert store.read_record(tmp_path, "a").clips[0].parts == "head"


def test_corrupt_record_counts_as_not_built(tmp_path: Path) -> None:
    clips = [clip("a")]
    store.write_take(tmp_path, record=record("a", clips), clips=clips)
    store.take_json(tmp_path, "a").write_text("{truncated")
    assert store.read_record(tmp_path, "a") is None
    assert not store.is_built(tmp_path, take_id="a", config_digest="d1")


def test_an_interrupted_write_leaves_the_old_take_and_only_temporaries(tmp_path: Path) -> None:
    clips = [clip("a")]
    store.write_take(tmp_path, record=record("a", clips), clips=clips)
    before = store.clip_npz(tmp_path, take_id="a", clip_id="a__c000").read_bytes()

    class Boom(Clip):
        def to_arrays(self) -> dict[str, np.ndarray]:
            raise KeyboardInterrupt

    bad = Boom(**{f: getattr(clips[0], f) for f in clips[0].__dataclass_fields__})
    with pytest.raises(KeyboardInterrupt):
        store.write_take(tmp_path, record=record("a", [bad], digest="d2"), clips=[bad])
    assert store.clip_npz(tmp_path, take_id="a", clip_id="a__c000").read_bytes() == before
    assert store.read_record(tmp_path, "a").config_digest == "d1"
    assert not [p for p in (tmp_path / "takes").iterdir() if p.name.startswith(".")]


def test_manifest_has_a_row_per_clip_and_per_span(tmp_path: Path) -> None:
    a = [clip("a"), clip("a", 1, seed=1)]
    span = store.ClipRecord("a__s000", "span", 4.0, 9.5, "rejected", ("main speaker absent",))
    store.write_take(tmp_path, record=record("a", a, spans=[span], traits={"age": "30"}), clips=a)
    failed = store.TakeRecord("c", "s2", "c.mp4", "d1", failed="c.mp4: corrupt", seconds=7.0)
    store.write_take(tmp_path, record=failed)
    table = store.write_manifest(tmp_path, store.take_records(tmp_path))
    rows = table.to_pylist()
    assert [(r["clip_id"], r["kind"], r["qc_status"]) for r in rows] == [
        ("a__c000", "clip", "accepted"),
        ("a__c001", "clip", "accepted"),
        ("a__s000", "span", "rejected"),
        ("c", "span", "failed"),
    ]
    assert rows[2]["qc_reasons"] == ["main speaker absent"]
    assert (rows[2]["start_s"], rows[2]["end_s"]) == (4.0, 9.5)
    assert rows[3]["end_s"] == 7.0 and rows[3]["qc_reasons"] == ["c.mp4: corrupt"]
    assert dict(rows[0]["traits"]) == {"age": "30"}


def test_a_dataset_read_with_pandas_and_numpy_alone(tmp_path: Path) -> None:
    """What a user's script sees, without any gesturebank code."""
    takes = {"s1_a": [clip("s1_a"), clip("s1_a", 1, seed=1)], "s2_b": [clip("s2_b", seed=2)]}
    out = write_dataset(tmp_path, takes)
    info = json.loads((out / "dataset.json").read_text())
    assert info["schema_version"] == 5
    manifest = pd.read_parquet(out / "manifest.parquet")
    # synthetic clips: exact joints (confidence 1), no lifter with a calibration (NaN)
    assert (manifest["depth_confidence"] == 1.0).all()
    assert manifest["expected_hand_error_cm"].isna().all()
    assert list(manifest["partner_clip_id"]) == ["", "", ""]  # one person per take: no partner
    assert list(manifest["clip_id"]) == ["s1_a__c000", "s1_a__c001", "s2_b__c000"]
    assert manifest["person"].dtype == np.int32 and (manifest["person"] >= 0).all()
    assert manifest["speaking_fraction"].between(0, 1).all()
    assert list(manifest["parts"]) == ["head+arms"] * 3
    for row in manifest.itertuples():
        path = out / "takes" / row.take_id / f"{row.clip_id}.npz"
        with np.load(path, allow_pickle=False) as d:
            assert d["angles"].shape == (row.n_frames, len(info["joints"]))
            assert d["audio"].shape == (row.n_frames, 26)
            assert d["times"][0] == 0.0  # each clip on its own clock
            assert d["mask"].dtype == bool
            assert d["depth_confidence"].shape == d["timestamps"].shape
            assert d["depth_confidence"].dtype == np.float32
            assert d["role"].shape == (row.n_frames,) and d["role"].dtype == np.int8
            assert d["head_roll"].shape == (row.n_frames,) and d["head_roll"].dtype == np.float32
            assert d["head_source"].shape == d["timestamps"].shape
            assert d["head_source"].dtype == np.int8
            assert str(d["partner_clip_id"]) == "" and not d["partner_speaking"].any()
    assert set(info["takes"]) == {"s1_a", "s2_b"}
    assert info["takes"]["s1_a"]["clips"] == 2


def test_reader_and_schema_1_message(tmp_path: Path) -> None:
    takes = {"s1_a": [clip("s1_a"), clip("s1_a", 1, seed=1)]}
    out = write_dataset(tmp_path, takes)
    ds = gesturebank.datasets.open(out)
    assert len(ds) == 2 and ds.clip_ids() == ["s1_a__c000", "s1_a__c001"]
    loaded = ds.load("s1_a__c001")
    np.testing.assert_array_equal(loaded.angles, takes["s1_a"][1].angles)
    assert loaded.pose2d.skeleton == takes["s1_a"][1].pose2d.skeleton
    assert [row.clip.clip_id for row, _ in ds] == ["s1_a__c000", "s1_a__c001"]
    assert ds.clip_ids(require="head") == ds.clip_ids(require="arms+head") == ds.clip_ids()
    assert gesturebank.datasets.open(out, require="left_arm").clip_ids() == ds.clip_ids()
    with pytest.raises(InputError, match="body parts 'hands'"):
        ds.clip_ids(require="hands")
    with pytest.raises(InputError, match="no clip 'nope'"):
        ds.load("nope")
    (out / "dataset.json").write_text(json.dumps({"schema_version": 1}))
    with pytest.raises(InputError) as exc:
        gesturebank.datasets.open(out)
    assert "schema_version 1" in str(exc.value) and "rebuild" in str(exc.value)
    assert "\n" not in str(exc.value)


def test_rows_are_the_records_the_manifest_holds(tmp_path: Path) -> None:
    """A manifest row is a clip's (or span's) record with its take's: as the take's JSON has
    them, but for what the manifest does not hold (tracking, audio sums, preview times, the
    measuring digest); a failed take is one span. Dict access still answers, deprecated."""
    out = write_dataset(tmp_path, {"s1_a": [clip("s1_a"), clip("s1_a", 1, seed=1)]})
    failed = store.TakeRecord("s2_b", "s2", "s2_b.mp4", "x", failed="no audio track", seconds=3.0)
    store.write_record(out, failed)
    refresh(out, Config())
    rows = gesturebank.datasets.open(out).rows()
    assert [(r.clip.clip_id, r.clip.kind) for r in rows] == [
        ("s1_a__c000", "clip"),
        ("s1_a__c001", "clip"),
        ("s2_b", "span"),
    ]
    assert rows[2].clip.qc_status == "failed" and rows[2].clip.qc_reasons == ("no audio track",)
    for row in rows:
        record = store.read_record(out, row.take.take_id)
        assert record is not None
        clips = tuple(replace(c, measured="") for c in record.clips)
        held = replace(record, tracking={}, audio={}, preview_times=(), clips=clips)
        assert json.dumps(row.take.to_json_dict()) == json.dumps(held.to_json_dict())
    assert rows[0].take is rows[1].take  # one record per take
    with pytest.warns(DeprecationWarning, match=r"row.take.subject"):
        assert rows[0]["subject"] == "s1"
    with pytest.warns(DeprecationWarning, match=r"row.clip.n_frames"):
        assert rows[1]["n_frames"] == rows[1].clip.n_frames > 0


def test_open_names_the_problem(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="dataset.json: not found"):
        gesturebank.datasets.open(tmp_path)
    (tmp_path / "dataset.json").write_text("{")
    with pytest.raises(InputError, match="not valid JSON"):
        gesturebank.datasets.open(tmp_path)


def test_refresh_znorm_from_the_per_take_sums(tmp_path: Path) -> None:
    """The z-norm stats combined from each take's sums equal those of all frames at once."""
    rng = np.random.default_rng(0)
    clips = {}
    for take in ("s1_a", "s1_b", "s2_a"):
        c = clip(take, seed=len(clips))
        audio = rng.normal(3.0, 2.0, c.audio.shape).astype(np.float32)
        clips[take] = [
            Clip(**{**{f: getattr(c, f) for f in c.__dataclass_fields__}, "audio": audio})
        ]
    out = write_dataset(tmp_path, clips)
    z = store.read_dataset_json(out).audio_znorm_by_subject
    s1 = np.concatenate([clips["s1_a"][0].audio, clips["s1_b"][0].audio]).astype(np.float64)
    np.testing.assert_allclose(z["s1"].mean, s1.mean(axis=0), rtol=1e-9)
    np.testing.assert_allclose(z["s1"].std, s1.std(axis=0), rtol=1e-6)
    every = np.concatenate([c[0].audio for c in clips.values()]).astype(np.float64)
    np.testing.assert_allclose(z["*"].std, every.std(axis=0), rtol=1e-6)
    assert set(z) == {"s1", "s2", "*"}
    # a second refresh with the same config rewrites no take record
    mtimes = {p: p.stat().st_mtime_ns for p in (out / "takes").glob("*.json")}
    refresh(out, Config())
    assert {p: p.stat().st_mtime_ns for p in (out / "takes").glob("*.json")} == mtimes
    assert pq.read_table(out / "manifest.parquet").num_rows == 3


def test_files_and_folders_follow_the_umask(tmp_path: Path) -> None:
    """Temporary files are private; what lands under the final name is readable as the umask
    says (a lab mate can read a dataset)."""
    import os
    import stat

    old = os.umask(0o022)
    try:
        clips = [clip("a")]
        store.write_take(tmp_path, record=record("a", clips), clips=clips)
    finally:
        os.umask(old)
    for path in (
        store.take_dir(tmp_path, "a"),
        store.clip_npz(tmp_path, take_id="a", clip_id="a__c000"),
    ):
        mode = stat.S_IMODE(path.stat().st_mode)
        assert mode == (0o755 if path.is_dir() else 0o644), (path, oct(mode))
    assert stat.S_IMODE(store.take_json(tmp_path, "a").stat().st_mode) == 0o644


@pytest.mark.parametrize("old", [3, 4])
def test_an_older_schema_dataset_is_refused_with_one_rebuild_line(tmp_path: Path, old: int) -> None:
    """Schema 4 added `depth_confidence` to every clip, schema 5 `head_source`: a dataset
    written before is refused by every reader with one line that says how to rebuild it."""
    out = write_dataset(tmp_path, {"s1_a": [clip("s1_a")]})
    info = json.loads((out / "dataset.json").read_text())
    (out / "dataset.json").write_text(json.dumps({**info, "schema_version": old}))
    with pytest.raises(InputError) as exc:
        gesturebank.datasets.open(out)
    message = str(exc.value)
    assert "\n" not in message
    assert f"schema_version {old}, this gesturebank reads 5 ({store.SCHEMA_CONTENT})" in message
    assert f"rebuild it with build-dataset VIDEOS_DIR {out} --force" in message


def test_head_source_travels_with_the_clip_and_is_checked(tmp_path: Path) -> None:
    """`head_source` is written and read back as (T,) int8 codes of HEAD_SOURCES; another
    shape, dtype or code is refused where the clip is made; a clip file without it is refused
    by name."""
    c = clip("s1_a")
    t = len(c.timestamps)
    source = (np.arange(t) % len(HEAD_SOURCES)).astype(np.int8)
    c = replace(c, head_source=source)
    out = write_dataset(tmp_path, {"s1_a": [c]})
    loaded = gesturebank.datasets.open(out).load(c.clip_id)
    np.testing.assert_array_equal(loaded.head_source, source)
    for bad in (source[:-1], source.astype(np.int64), np.full(t, 3, np.int8)):
        with pytest.raises(InputError, match="head_source must be"):
            replace(c, head_source=bad)
    arrays = {k: v for k, v in c.to_arrays().items() if k != "head_source"}
    with pytest.raises(InputError, match="lack 'head_source'"):
        Clip.from_arrays(arrays)


def test_speech_travels_with_the_clip_and_is_checked(tmp_path: Path) -> None:
    """`speech` is written and read back as (N,) bool; another shape or dtype is refused where
    the clip is made (so never written)."""
    c = clip("s1_a")
    speech = np.arange(len(c.times)) % 7 < 4
    c = replace(c, speech=speech)
    out = write_dataset(tmp_path, {"s1_a": [c]})
    loaded = gesturebank.datasets.open(out).load(c.clip_id)
    assert loaded.speech.dtype == np.bool_
    np.testing.assert_array_equal(loaded.speech, speech)
    with pytest.raises(InputError, match="speech must be"):
        replace(c, speech=speech[:-1])
    with pytest.raises(InputError, match="speech must be bool, got float"):
        replace(c, speech=speech.astype(np.float32))


def test_depth_confidence_travels_with_the_clip_and_is_checked(tmp_path: Path) -> None:
    """`depth_confidence` is written and read back as (T,) float32 with its mean and the hand
    error it predicts in the manifest; another shape, dtype or a value outside [0, 1] (or NaN)
    is refused where the clip is made (so never written)."""
    c = clip("s1_a")
    t = len(c.timestamps)
    confidence = np.linspace(0.2, 1.0, t).astype(np.float32)
    lifted = replace(c.pose3d, meta={"lifter": "blazepose-world"})
    c = replace(c, depth_confidence=confidence, pose3d=lifted)
    out = write_dataset(tmp_path, {"s1_a": [c]})
    loaded = gesturebank.datasets.open(out).load(c.clip_id)
    np.testing.assert_array_equal(loaded.depth_confidence, confidence)
    row = pd.read_parquet(out / "manifest.parquet").iloc[0]
    assert row["depth_confidence"] == pytest.approx(float(confidence.mean()))
    assert np.isfinite(row["expected_hand_error_cm"]) and row["expected_hand_error_cm"] > 0
    for bad in (confidence[:-1], confidence.astype(np.float64), confidence + 0.5):
        with pytest.raises(InputError, match="depth_confidence must be"):
            replace(c, depth_confidence=bad)
    with pytest.raises(InputError, match="depth_confidence must be float32 in"):
        replace(c, depth_confidence=np.full(t, np.nan, np.float32))
