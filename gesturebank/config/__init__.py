"""Configuration: one validated pydantic model per stage, loaded from TOML, overridden on the CLI.

Precedence is defaults < file < command-line flags. The fully resolved config is what gets saved
with every output (and hashed, so a re-run knows whether a built take is still valid). Every
field says its unit and when to change it; `gesturebank.toml` is the commented example of the
same, shipped in the package as gesturebank/data/gesturebank.toml (`commented_example`,
`gesturebank config --commented`; the repository's top-level file is that one, linked).

Each stage's sections are a module of this package (extract, audio, repair, lift, robot,
datasets, qc, train, mocap, synth; `Section` is their base); this module assembles them into
`Config`, loads TOML and re-exports every name, so `from gesturebank.config import X` is the
one import for any of them.
"""

from __future__ import annotations

import difflib
import hashlib
import json
import os
import re
import tomllib
from collections.abc import Iterable, Mapping
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import BaseModel, Field, ValidationError, model_validator

from gesturebank.config.audio import AudioConfig, FeatureKind, SpeechConfig
from gesturebank.config.datasets import (
    BuildConfig,
    ClipsConfig,
    Executor,
    ProcessingConfig,
    SplitsConfig,
)
from gesturebank.config.extract import (
    BlazePoseConfig,
    DetectorConfig,
    MediaPipeConfig,
    OpenPoseJsonConfig,
    ShotsConfig,
    TrackingConfig,
    VideoConfig,
)
from gesturebank.config.lift import (
    OLD_LIFTER_SECTIONS,
    BoardConfig,
    FittedConfig,
    GeometricConfig,
    LearnedConfig,
    LifterConfig,
    MultiviewConfig,
    ResolvedConfig,
)
from gesturebank.config.mocap import MocapConfig, MocapUnits
from gesturebank.config.qc import MetricName, QCConfig
from gesturebank.config.repair import RepairConfig
from gesturebank.config.robot import PlaybackConfig, RenderConfig, RetargetConfig, RobotConfig
from gesturebank.config.section import PluginSections, Section, deprecated_key, nest
from gesturebank.config.synth import SynthConfig, SynthLook
from gesturebank.config.train import (
    Aud2MotionConfig,
    Aud2PoseConfig,
    Aud2Repr2PoseConfig,
    CVAEConfig,
    DCCCAEConfig,
    EvalConfig,
    FCGRUConfig,
    LSTMConfig,
    MLPConfig,
    RMSpropScheduleConfig,
    SpanBLSTMConfig,
    Target,
    TrainConfig,
    Variant,
)
from gesturebank.errors import ConfigError

__all__ = [
    "Aud2MotionConfig",
    "Aud2PoseConfig",
    "Aud2Repr2PoseConfig",
    "AudioConfig",
    "BlazePoseConfig",
    "BoardConfig",
    "BuildConfig",
    "CVAEConfig",
    "ClipsConfig",
    "Config",
    "DCCCAEConfig",
    "DetectorConfig",
    "EvalConfig",
    "Executor",
    "FCGRUConfig",
    "FeatureKind",
    "FittedConfig",
    "GeometricConfig",
    "LSTMConfig",
    "LearnedConfig",
    "LifterConfig",
    "MLPConfig",
    "MediaPipeConfig",
    "MetricName",
    "MocapConfig",
    "MocapUnits",
    "MultiviewConfig",
    "OpenPoseJsonConfig",
    "PlaybackConfig",
    "PluginSections",
    "ProcessingConfig",
    "QCConfig",
    "RMSpropScheduleConfig",
    "RenderConfig",
    "RepairConfig",
    "ResolvedConfig",
    "RetargetConfig",
    "RobotConfig",
    "Section",
    "ShotsConfig",
    "SpanBLSTMConfig",
    "SpeechConfig",
    "SplitsConfig",
    "SynthConfig",
    "SynthLook",
    "Target",
    "TrackingConfig",
    "TrainConfig",
    "Variant",
    "VideoConfig",
    "commented_example",
    "load_config",
    "parse_override",
]


class Config(Section):
    """The resolved configuration of every stage."""

    video: VideoConfig = Field(default_factory=VideoConfig)
    detector: DetectorConfig = Field(default_factory=DetectorConfig)
    shots: ShotsConfig = Field(default_factory=ShotsConfig)
    tracking: TrackingConfig = Field(default_factory=TrackingConfig)
    repair: RepairConfig = Field(default_factory=RepairConfig)
    clips: ClipsConfig = Field(default_factory=ClipsConfig)
    lifter: LifterConfig = Field(default_factory=LifterConfig)
    board: BoardConfig = Field(default_factory=BoardConfig)
    robot: RobotConfig = Field(default_factory=RobotConfig)
    retarget: RetargetConfig = Field(default_factory=RetargetConfig)
    processing: ProcessingConfig = Field(default_factory=ProcessingConfig)
    audio: AudioConfig = Field(default_factory=AudioConfig)
    speech: SpeechConfig = Field(default_factory=SpeechConfig)
    qc: QCConfig = Field(default_factory=QCConfig)
    splits: SplitsConfig = Field(default_factory=SplitsConfig)
    train: TrainConfig = Field(default_factory=TrainConfig)
    playback: PlaybackConfig = Field(default_factory=PlaybackConfig)
    render: RenderConfig = Field(default_factory=RenderConfig)
    mocap: MocapConfig = Field(default_factory=MocapConfig)
    synth: SynthConfig = Field(default_factory=SynthConfig)
    build: BuildConfig = Field(default_factory=BuildConfig)

    @model_validator(mode="before")
    @classmethod
    def _moved(cls, data: Any) -> Any:
        # [geometric] … [multiview] became [lifter.geometric] … (read for one release)
        for old in OLD_LIFTER_SECTIONS:
            if isinstance(data, dict) and old in data:
                deprecated_key(f"[{old}]", f"[lifter.{old}]")
                rest = {k: v for k, v in data.items() if k != old}
                data = nest(rest, "lifter", values={old: data[old]})
        # playback.sim_fps became render.frame_rate (datasets and config files with it still load)
        playback = data.get("playback") if isinstance(data, dict) else None
        if isinstance(playback, dict) and "sim_fps" in playback:
            render = dict(data.get("render") or {})
            render.setdefault("frame_rate", playback["sim_fps"])
            data = {**data, "render": render}
        return data

    def to_json_dict(self) -> dict[str, Any]:
        return self.model_dump(mode="json", by_alias=True)

    def digest(self, *sections: str) -> str:
        """sha256 of the given sections (all when none), to key caches and resumable builds."""
        data = self.to_json_dict()
        if sections:
            data = {s: data[s] for s in sections}
        return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:16]


def commented_example() -> str:
    """The commented gesturebank.toml shipped in the package: every key, its unit, its default."""
    return resources.files("gesturebank").joinpath("data/gesturebank.toml").read_text("utf-8")


def _error_line(source: str, exc: ValidationError, text: str | None = None) -> str:
    """One line per problem, naming the dotted key: 'file.toml:7: audio.nfilt: ...'.

    An unknown key names the nearest valid one ("did you mean max_epochs?"); with the file's
    `text`, the line of the key is given too.
    """
    lines = []
    for err in exc.errors():
        loc = tuple(str(p) for p in err["loc"])
        key = ".".join(loc) or "(top level)"
        msg = err["msg"]
        if err["type"] == "extra_forbidden":
            msg = "unknown key" + _suggestion(loc)
        elif "input" in err and not isinstance(err["input"], dict | list):
            msg = f"{msg} (got {err['input']!r})"
        line = _line_of(text, loc) if text is not None else None
        where = source if line is None else f"{source}:{line}"
        lines.append(f"{where}: {key}: {msg}")
    return "; ".join(lines)


def _section_model(path: tuple[str, ...]) -> type[BaseModel] | None:
    """The config model at a dotted path of sections (None when the path leaves the models)."""
    model: type[BaseModel] = Config
    for name in path:
        field = model.model_fields.get(name)
        inner = field.annotation if field is not None else None
        if not (isinstance(inner, type) and issubclass(inner, BaseModel)):
            return None
        model = inner
    return model


def _suggestion(loc: tuple[str, ...]) -> str:
    """' (did you mean NAME?)' for an unknown key, from the valid keys of its section (or
    them all, when none is close and they are few)."""
    model = _section_model(loc[:-1])
    if model is None or not loc:
        return ""
    keys = list(model.model_fields)
    close = difflib.get_close_matches(loc[-1], keys, n=1, cutoff=0.6)
    if close:
        return f" (did you mean {close[0]}?)"
    return f" (valid: {', '.join(keys)})" if len(keys) <= 12 else " (see `gesturebank config`)"


_TABLE = re.compile(r"^\s*\[\[?\s*([^\]]+?)\s*\]\]?")
_KEY = re.compile(r"^\s*([A-Za-z0-9_\-.\"' ]+?)\s*=")


def _dotted(name: str) -> tuple[str, ...]:
    return tuple(part.strip().strip("\"'") for part in name.split("."))


def _line_of(text: str, loc: tuple[str, ...]) -> int | None:
    """1-based line of the TOML `text` that defines the key at `loc` (or opens its table)."""
    table: tuple[str, ...] = ()
    for number, line in enumerate(text.splitlines(), start=1):
        if m := _TABLE.match(line):
            table = _dotted(m.group(1))
            if table[: len(loc)] == loc:  # an unknown section: its header
                return number
        elif m := _KEY.match(line):
            path = (*table, *_dotted(m.group(1)))
            if path[: len(loc)] == loc:
                return number
    return None


def _merge(base: dict[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, Mapping) and isinstance(out.get(k), dict) else v
    return out


def parse_override(item: str) -> dict[str, Any]:
    """'audio.nfilt=40' → {'audio': {'nfilt': 40}}; the value is read as TOML (else a string)."""
    key, sep, raw = item.partition("=")
    if not sep or not key.strip():
        raise ConfigError(f"--set {item!r}: expected SECTION.KEY=VALUE")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()
    nested: dict[str, Any] = {}
    cur = nested
    parts = key.strip().split(".")
    for p in parts[:-1]:
        cur = cur.setdefault(p, {})
    cur[parts[-1]] = value
    return nested


def load_config(
    path: str | os.PathLike[str] | None = None,
    overrides: Iterable[Mapping[str, Any]] = (),
    *,
    base: Config | None = None,
) -> Config:
    """Defaults (or `base`) < the TOML file at `path` < each mapping of `overrides` in turn.

    Raises ConfigError with one line naming the file (or "command line") and the key.
    """
    data: dict[str, Any] = {} if base is None else base.to_json_dict()
    source = "defaults"
    if path is not None:
        source = os.fspath(path)
        try:
            text = Path(path).read_text(encoding="utf-8")
            from_file = tomllib.loads(text)
        except FileNotFoundError:
            raise ConfigError(f"{source}: config file not found") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise ConfigError(f"{source}: cannot read config file ({exc})") from None
        except tomllib.TOMLDecodeError as exc:
            raise ConfigError(f"{source}: not valid TOML ({exc})") from None
        try:
            Config.model_validate(from_file)
        except ValidationError as exc:
            raise ConfigError(_error_line(source, exc, text)) from None
        data = _merge(data, from_file)
    for over in overrides:
        data = _merge(data, over)
    try:
        return Config.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(_error_line("command line", exc)) from None
