"""`gesturebank stimuli`: blind videos rendered from real models and a real dataset clip."""

from __future__ import annotations

import json
import re
from pathlib import Path

import av
import pytest

from gesturebank import datasets
from gesturebank.cli.training import train_command
from gesturebank.config import RenderConfig, TrainConfig
from gesturebank.errors import InputError
from gesturebank.study.stimuli import KEY, MANIFEST, parse_clip, stimuli_command

ONE_EPOCH = TrainConfig.model_validate({"mlp": {"max_epochs": 1}, "lstm": {"max_epochs": 1}})
SMALL = RenderConfig(frame_rate=10, width_px=160, height_px=120)


@pytest.fixture(scope="module")
def models(demo_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    root = tmp_path_factory.mktemp("models")
    for name in ("mlp", "lstm"):
        train_command(
            demo_dataset,
            model=name,
            variant="sd",
            fold=None,
            subject="lab",
            out_dir=root / name,
            config=ONE_EPOCH,
            quiet=True,
        )
    return [root / "mlp", root / "lstm"]


def streams(path: Path) -> tuple[int, float, bool]:
    """(video frames, duration s, has audio) of a decoded MP4."""
    with av.open(str(path)) as c:
        has_audio = bool(c.streams.audio)
        n = sum(1 for _ in c.decode(video=0))
        return n, float(c.duration or 0) / 1e6, has_audio


def test_stimuli_are_blind_keyed_apart_and_alike(
    models: list[Path], demo_dataset: Path, samples: Path, tmp_path: Path
) -> None:
    wav = samples / "speech" / "arctic_a0009.wav"
    clip = datasets.open(demo_dataset).clip_ids(None)[0]
    out = tmp_path / "study"
    manifest = stimuli_command(
        model_dirs=models, out=out, audios=[wav], clips=[f"{demo_dataset}:{clip}"], render=SMALL
    )
    assert json.loads((out / MANIFEST).read_text()) == manifest
    key = json.loads((out / KEY).read_text())["videos"]
    groups = {g["audio"]: g for g in manifest["groups"]}
    assert list(groups) == ["arctic_a0009", clip]
    # two models + the anchor for the audio; + the ground truth for the clip
    assert len(groups["arctic_a0009"]["videos"]) == 3 and len(groups[clip]["videos"]) == 4
    roles = {g: sorted(key[v["id"]]["role"] for v in groups[g]["videos"]) for g in groups}
    assert roles == {
        "arctic_a0009": ["anchor", "model", "model"],
        clip: ["anchor", "model", "model", "reference"],
    }
    assert {key[v["id"]]["condition"] for v in groups[clip]["videos"]} == {
        "mlp",
        "lstm",
        "ground-truth",
        "anchor",
    }
    # blind: random ids as names, nothing of a condition in the manifest or the video folder
    text = (out / MANIFEST).read_text()
    for word in ("mlp", "lstm", "ground", "anchor", "reference", "model", str(models[0])):
        assert word not in text
    ids = [v["id"] for g in manifest["groups"] for v in g["videos"]]
    assert len(set(ids)) == len(ids) == len(key)
    assert all(re.fullmatch(r"[0-9a-f]{10}", i) for i in ids)
    assert sorted(p.name for p in (out / "videos").iterdir()) == sorted(f"{i}.mp4" for i in ids)
    # a poster frame for each, made with it, of the video's size
    assert sorted(p.name for p in (out / "posters").iterdir()) == sorted(f"{i}.jpg" for i in ids)
    from PIL import Image

    with Image.open(out / "posters" / f"{ids[0]}.jpg") as poster:
        assert poster.size == (SMALL.width_px, SMALL.height_px)
    # every video of one speech: same frame count and duration (the audio's), audio muxed
    for g in manifest["groups"]:
        seen = {streams(out / v["file"]) for v in g["videos"]}
        assert len({(n, has) for n, _, has in seen}) == 1, seen
        n, duration, has_audio = seen.pop()
        assert has_audio and n == round(g["duration_s"] * SMALL.frame_rate)
        assert duration == pytest.approx(g["duration_s"], abs=0.15)
    # what `study serve` reads: one MUSHRA page per speech and the A/B pair of the two models
    from gesturebank.study.design import load_design

    design = load_design(out)
    kinds = sorted((t.kind, t.audio) for t in design.trials.values())
    assert kinds == sorted([("mushra", a) for a in groups] + [("ab", a) for a in groups])


def test_a_malformed_clip_is_one_line() -> None:
    assert parse_clip("out/ds:take1_c002") == (Path("out/ds"), "take1_c002")
    with pytest.raises(InputError, match="expected DATASET_DIR:CLIP_ID"):
        parse_clip("take1_c002")


def test_random_clip_anchor_is_another_clip(
    models: list[Path], demo_dataset: Path, tmp_path: Path
) -> None:
    ds = datasets.open(demo_dataset)
    clip = ds.clip_ids(None)[0]
    out = tmp_path / "study"
    manifest = stimuli_command(
        model_dirs=models[:1],
        out=out,
        clips=[f"{demo_dataset}:{clip}"],
        anchor="random-clip",
        render=SMALL,
    )
    key = json.loads((out / KEY).read_text())["videos"]
    by_role = {key[v["id"]]["role"]: v for v in manifest["groups"][0]["videos"]}
    assert key[by_role["anchor"]["id"]]["anchor"] == "random-clip"
    with av.open(str(out / by_role["anchor"]["file"])) as a:
        anchor = [f.to_ndarray(format="rgb24") for f in a.decode(video=0)]
    with av.open(str(out / by_role["reference"]["file"])) as r:
        truth = [f.to_ndarray(format="rgb24") for f in r.decode(video=0)]
    assert len(anchor) == len(truth)
    # another clip's motion: some frame differs from the ground truth's
    diffs = [abs(x.astype(int) - y.astype(int)).mean() for x, y in zip(anchor, truth, strict=True)]
    assert max(diffs) > 0.5
