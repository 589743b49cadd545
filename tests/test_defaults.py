"""Every default is defined once, as the pydantic field: a function keyword named like a field
of a config section has no default or None (the function takes the section, or the caller passes
the field) — a copy of the field's default is a second definition that can drift."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from collections.abc import Callable, Iterator
from types import ModuleType
from typing import Any

from pydantic import BaseModel

import gesturebank
from gesturebank import config

# Same name, another meaning (not a mirror of the field): (function, parameter) → why.
UNRELATED = {
    ("gesturebank.datasets.records.TakeRecord.__init__", "detector"): "the take's 2D detector name",
    ("gesturebank.poses.Pose3D.__init__", "units"): "the pose's own unit, not a lifter choice",
    ("gesturebank.extract.detectors.blazepose.postprocess.refine_from_heatmap", "min_confidence"): (
        "BlazePose's heatmap-refinement threshold, not a lifter's keypoint confidence"
    ),
    ("gesturebank.lift.multiview.sync.motion_signal", "min_confidence"): (
        "keypoints trusted for the sync signal, not for triangulation"
    ),
    ("gesturebank.lift.multiview.sync.motion_signal", "cutoff_hz"): (
        "low-pass of the sync signal, not of the angles"
    ),
    ("gesturebank.robot.audio_out.DeviceAudio.__init__", "sample_rate"): (
        "the sound device's rate, not the features' audio rate"
    ),
    ("gesturebank.testing.tiny_models.write_model_dir", "kind"): (
        "the test model's architecture (lstm or mlp), not a calibration board's kind"
    ),
    ("gesturebank.testing.clips.synthetic_clip", "seed"): (
        "the synthetic clip's own random draw, not the splits' or the trainer's seed"
    ),
    ("gesturebank.lift.agreement.bootstrap_over_clips", "seed"): (
        "the bootstrap's own random draw of clips, not the splits' or the trainer's seed"
    ),
    ("gesturebank.lift.agreement.agreement", "seed"): (
        "the bootstrap's own random draw of clips, not the splits' or the trainer's seed"
    ),
    ("gesturebank.lift.training.lifter_net.Schedule.__init__", "workers"): (
        "processes making the lifter's training batches, not the build's workers"
    ),
    ("gesturebank.lift.training.lifter_views.CameraRanges.__init__", "distance_m"): (
        "the range training cameras are drawn from, not a render's camera distance"
    ),
    ("gesturebank.lift.training.lifter_views.CameraRanges.__init__", "fov_deg"): (
        "the range training cameras are drawn from, not a render's or a lifter's field of view"
    ),
    ("gesturebank.testing.corrupt.corrupt", "seed"): (
        "the corruption's own random draw, not the splits' or the trainer's seed"
    ),
    ("gesturebank.testing.speech_motion.write_speech_motion_dataset", "seed"): (
        "the synthetic dataset's own random draw, not the splits' or the trainer's seed"
    ),
    ("gesturebank.testing.dyads.write_dyad_dataset", "seed"): (
        "the generated dataset's own random draw, not the splits' or the trainer's seed"
    ),
    ("gesturebank.testing.corrupt.corrupt", "target"): (
        "what the corruption hits (pose or angles), not what a model predicts"
    ),
    ("gesturebank.testing.tiny_models.write_model_dir", "seed"): (
        "the test model's random weights, not the splits' or the trainer's seed"
    ),
    ("gesturebank.train.export.OnnxModel.__init__", "threads"): (
        "onnxruntime threads of one inference session, not torch's training threads"
    ),
    ("gesturebank.train.export.StreamingLSTM.__init__", "threads"): (
        "onnxruntime threads of one inference session, not torch's training threads"
    ),
    ("gesturebank.train.model_folder.session", "threads"): (
        "onnxruntime threads of one inference session, not torch's training threads"
    ),
    ("gesturebank.export.trc.format_trc", "units"): "the TRC file's unit, not a lifter choice",
    ("gesturebank.mocap.bvh.parse_bvh", "name"): "the file named in errors, not a stage's name",
    ("gesturebank.testing.mocap.mocap_take", "name"): "the take's file stem, not a stage's name",
}


def field_defaults() -> dict[str, list[Any]]:
    """Field name → the defaults it has in the config sections (sections themselves left out)."""
    found: dict[str, list[Any]] = {}
    for cls in vars(config).values():
        if not (inspect.isclass(cls) and issubclass(cls, config.Section)):
            continue
        for name, field in cls.model_fields.items():
            kind = field.annotation
            if inspect.isclass(kind) and issubclass(kind, BaseModel):
                continue
            found.setdefault(name, []).append(field.get_default(call_default_factory=True))
    return found


def public_functions(module: ModuleType) -> Iterator[tuple[str, Callable[..., Any]]]:
    """Public functions of `module` and the public methods and constructors of its classes."""
    for name, obj in vars(module).items():
        if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
            continue
        if inspect.isfunction(obj):
            yield f"{module.__name__}.{name}", obj
        elif inspect.isclass(obj) and not issubclass(obj, BaseModel):
            for attr, member in vars(obj).items():
                if (attr == "__init__" or not attr.startswith("_")) and inspect.isfunction(member):
                    yield f"{module.__name__}.{name}.{attr}", member


def _same(default: Any, field_default: Any) -> bool:
    if isinstance(default, tuple | list) and isinstance(field_default, tuple | list):
        return tuple(default) == tuple(field_default)
    return bool(default == field_default)


def repeated(
    functions: Iterator[tuple[str, Callable[..., Any]]], fields: dict[str, list[Any]]
) -> dict[tuple[str, str], Any]:
    """(function, parameter) → default, for every default (other than None) of a parameter
    named like a config field: drifted from the field's, or a copy of it."""
    found = {}
    for qualname, func in functions:
        for p in inspect.signature(func).parameters.values():
            if p.name not in fields or p.default is inspect.Parameter.empty or p.default is None:
                continue
            found[(qualname, p.name)] = p.default
    return found


def all_functions() -> Iterator[tuple[str, Callable[..., Any]]]:
    for info in pkgutil.walk_packages(gesturebank.__path__, "gesturebank."):
        yield from public_functions(importlib.import_module(info.name))


def _why(default: Any, field_defaults: list[Any]) -> str:
    if any(_same(default, d) for d in field_defaults):
        return "a copy of the config field's default: take the section or no default"
    return f"but the config field's default is {field_defaults}"


def test_function_defaults_are_the_config_fields_own() -> None:
    fields = field_defaults()
    found = repeated(all_functions(), fields)
    bad = {k: v for k, v in found.items() if k not in UNRELATED}
    assert not bad, "\n".join(f"{f}({p}={v!r}): {_why(v, fields[p])}" for (f, p), v in bad.items())
    stale = set(UNRELATED) - set(found)
    assert not stale, f"UNRELATED lists what no longer has a default: {sorted(stale)}"


def _example(
    signal: object,
    *,
    rate_hz: float,
    cutoff_hz: float = 6.0,
    butter_order: int = 5,
    gate: float | None = None,
    order: int = 5,
) -> None:
    """A drifted default (processing.cutoff_hz is 4 Hz), a copy of one (processing.butter_order
    is 5), a field without a default, a None and a keyword that is no field."""


def test_a_drifted_or_copied_default_is_found() -> None:
    fields = field_defaults()
    found = repeated(iter([("example", _example)]), fields)
    assert found == {("example", "cutoff_hz"): 6.0, ("example", "butter_order"): 5}
    assert _why(6.0, fields["cutoff_hz"]).startswith("but the config field's default is")
    assert _why(5, fields["butter_order"]).startswith("a copy of")
