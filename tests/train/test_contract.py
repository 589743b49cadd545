"""The model contract: every built-in keeps it (hooks where expected), a plug-in model brings
its own `[train.NAME]` section, and model.json reads as `ModelInfo`."""

from __future__ import annotations

import json
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest

import gesturebank.registry
from gesturebank.config import load_config
from gesturebank.errors import ConfigError, InputError
from gesturebank.train.contract import (
    ExtraOnnxInputs,
    FrameWise,
    OwnLoss,
    OwnValidation,
    SpeechToMotion,
    Staged,
    Stateful,
)
from gesturebank.train.model_folder import MODEL_JSON, ModelInfo
from gesturebank.train.models.build import architecture, build_model, from_architecture
from gesturebank.train.registry import MODELS
from tests.train.plugin_model import GainModel, GainSection

HOOKS = {
    "mlp": {FrameWise},
    "lstm": {Stateful},
    "aud2motion": {Stateful},
    "aud2pose": {OwnLoss},
    "blstm": set(),
    "cvae": {OwnLoss, ExtraOnnxInputs},
    "aud2repr2pose": {OwnLoss, OwnValidation, Staged},
    "dcccae": {OwnLoss, OwnValidation, Staged},
}


def test_builtins_keep_the_contract_with_their_hooks() -> None:
    assert set(HOOKS) == set(MODELS.names())
    cfg = load_config().train
    for kind, hooks in HOOKS.items():
        model = build_model(kind, 6, config=cfg)
        assert isinstance(model, SpeechToMotion) and model.kind == kind
        found = {h for h in (FrameWise, Stateful, OwnLoss, OwnValidation, Staged, ExtraOnnxInputs)
                 if isinstance(model, h)}  # fmt: skip
        assert found == hooks, kind


@pytest.fixture()
def gain_plugin(monkeypatch: pytest.MonkeyPatch) -> None:
    """ "gain" installed as a "gesturebank.models" entry point (the registry's cache restored)."""
    plugin = EntryPoint("gain", "tests.train.plugin_model:GainModel", "gesturebank.models")
    real = gesturebank.registry.entry_points

    def patched(*, group: str) -> list[EntryPoint]:
        return [*real(group=group), *([plugin] if group == "gesturebank.models" else [])]

    monkeypatch.setattr(gesturebank.registry, "entry_points", patched)
    monkeypatch.setattr(MODELS, "_factories", dict(MODELS._factories))


def test_plugin_section_is_validated_by_its_model(gain_plugin: None, tmp_path: Path) -> None:
    path = tmp_path / "c.toml"
    path.write_text("[train.gain]\nunits = 3\n")
    cfg = load_config(path).train
    assert cfg.model_extra == {"gain": GainSection(units=3)}
    model = build_model("gain", 5, config=cfg)
    assert isinstance(model, GainModel) and isinstance(model, SpeechToMotion)
    assert architecture(model) == {"kind": "gain", "n_features": 5, "units": 3}
    assert model.schedule(cfg).max_epochs == 2  # the plug-in section's default
    rebuilt = from_architecture(json.loads(json.dumps(architecture(model))))
    assert [p.shape for p in rebuilt.parameters()] == [p.shape for p in model.parameters()]
    # the section travels in the dumped config (model.json's train_config) and back
    dumped = cfg.model_dump(mode="json")
    assert dumped["gain"] == {"units": 3, "max_epochs": 2}
    assert type(cfg).model_validate(dumped).model_extra == cfg.model_extra


@pytest.mark.parametrize(
    ("toml", "said"),
    [
        ("[train.gain]\nunitz = 3\n", "train: gain.unitz: unknown key"),
        ("[train.gain]\nunits = 0\n", "train: gain.units: Input should be greater than or equal"),
        ("[train.gian]\nunits = 3\n", "train: gian: unknown key"),
        ("[train]\npatiense = 3\n", "train: patiense: unknown key (did you mean patience?)"),
    ],
)
def test_plugin_section_errors_are_one_line(
    gain_plugin: None, tmp_path: Path, toml: str, said: str
) -> None:
    path = tmp_path / "c.toml"
    path.write_text(toml)
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert said in str(err.value) and "\n" not in str(err.value)


def test_model_info_reads_what_train_wrote_and_live_only_folders(tmp_path: Path) -> None:
    audio = load_config().audio.model_dump(mode="json")
    live = ModelInfo.model_validate({"audio": audio})  # a folder for live mode only
    assert live.causal and live.reach is None and live.result is None
    with pytest.raises(InputError, match=r"model.json: no 'dataset'"):
        live.need(tmp_path, "dataset")
    written = {
        "tool_version": "0.1.0",
        "architecture": {"kind": "lstm", "n_features": 26, "units": 12},
        "causal": True,
        "variant": "sd",
        "target": "speaker",
        "fold": None,
        "subject": "s1",
        "dataset": "/data/ds",
        "train_config": {"seed": 0},
        "audio": audio,
        "rate_hz": 100.0,
        "reach": "soft",
        "require": None,
        "result": {"best_epoch": 1, "best_val_loss": float("inf"), "epochs": 1,
                   "max_epochs": 1, "stopped": "max epochs reached", "seconds": 0.5,
                   "history": [{"epoch": 1, "train_loss": 0.1, "val_loss": 0.2, "lr": 0.001}]},
    }  # fmt: skip
    text = json.dumps(written, indent=1)
    info = ModelInfo.model_validate(json.loads(text))
    assert info.subject == "s1" and info.result is not None and info.result.best_epoch == 1
    again = {**info.model_dump(), "audio": info.audio.model_dump(mode="json")}
    assert json.dumps(again, indent=1) == text  # the key order and values model.json has
    (tmp_path / MODEL_JSON).write_text(text.replace('"rate_hz": 100.0', '"rate_hz": "fast"'))
    with pytest.raises(ValueError, match="rate_hz"):
        ModelInfo.model_validate(json.loads((tmp_path / MODEL_JSON).read_text()))
