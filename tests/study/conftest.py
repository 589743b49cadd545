"""A small study folder made of real footage, laid out as `gesturebank stimuli` writes one
(formats in gesturebank.study.stimuli): two sentences of real speech, each with four
blind-named videos (two models, the ground truth, an anchor), the blind `stimuli.json` and the
operator's `key.json`. Real sample clips stand in for the renders, so that these tests do not
depend on the renderer."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from gesturebank import footage
from gesturebank.study.stimuli import FORMAT, KEY, KEY_FORMAT, MANIFEST

AUDIOS = ("arctic_a0007", "arctic_a0009")
MODELS = ("mlp", "lstm", "ground-truth", "anchor")
ROLES = {"mlp": "model", "lstm": "model", "ground-truth": "reference", "anchor": "anchor"}
SOURCES = {  # a different real clip per model, so the four videos look different
    "mlp": "talking/lab/cam01_arctic.mp4",
    "lstm": "talking/lab/cam03_arctic.mp4",
    "ground-truth": "talking/outdoor/sports2d_arctic.mp4",
    "anchor": "pose2sim/Demo_SinglePerson/videos/cam01.mp4",
}
SECONDS = 1.0
# Blind ids as the stimuli command makes them: random-looking, no model in them.
IDS = {
    (audio, model): f"s{(7 * a + 3 * m) % 10}{a}{m}x{'qwrt'[m]}"
    for a, audio in enumerate(AUDIOS)
    for m, model in enumerate(MODELS)
}


def write_study(folder: Path, samples: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    groups, key = [], {}
    for audio in AUDIOS:
        videos = []
        speech = footage.looped_speech([samples / "speech" / f"{audio}.wav"], seconds=SECONDS)
        for model in MODELS:
            sid = IDS[(audio, model)]
            frames = footage.load(samples / SOURCES[model], seconds=SECONDS)
            frames = footage.rescale(frames, size=(160, 120))
            footage.write(frames, folder / "videos" / f"{sid}.mp4", speech=speech)
            videos.append({"id": sid, "file": f"videos/{sid}.mp4"})
            key[sid] = {"audio": audio, "condition": model, "role": ROLES[model]}
        groups.append({"audio": audio, "duration_s": SECONDS, "videos": videos})
    manifest = {"format": FORMAT, "fps": 25, "width_px": 160, "height_px": 120, "groups": groups}
    (folder / MANIFEST).write_text(json.dumps(manifest, indent=1))
    (folder / KEY).write_text(json.dumps({"format": KEY_FORMAT, "videos": key}, indent=1))
    return folder


@pytest.fixture(scope="session")
def study_template(samples: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_study(tmp_path_factory.mktemp("study-template"), samples)


@pytest.fixture()
def study(study_template: Path, tmp_path: Path) -> Path:
    """A fresh copy (no database, no operator token yet) for each test."""
    return Path(shutil.copytree(study_template, tmp_path / "study"))
