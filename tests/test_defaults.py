"""Every default is defined once, as the pydantic field: a function keyword named like a field
of a config section either has no default, None, or exactly the field's default."""

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
    ("gesturebank.datasets.store.TakeRecord.__init__", "detector"): "the take's 2D detector name",
    ("gesturebank.poses.Pose3D.__init__", "units"): "the pose's own unit, not a lifter choice",
    ("gesturebank.extract.detectors.blazepose.refine_from_heatmap", "min_confidence"): (
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


def drifted(
    functions: Iterator[tuple[str, Callable[..., Any]]], fields: dict[str, list[Any]]
) -> dict[tuple[str, str], Any]:
    """(function, parameter) → default, for defaults that match no field of that name."""
    found = {}
    for qualname, func in functions:
        for p in inspect.signature(func).parameters.values():
            if p.name not in fields or p.default is inspect.Parameter.empty or p.default is None:
                continue
            if not any(_same(p.default, d) for d in fields[p.name]):
                found[(qualname, p.name)] = p.default
    return found


def all_functions() -> Iterator[tuple[str, Callable[..., Any]]]:
    for info in pkgutil.walk_packages(gesturebank.__path__, "gesturebank."):
        yield from public_functions(importlib.import_module(info.name))


def test_function_defaults_match_the_config_fields() -> None:
    found = drifted(all_functions(), field_defaults())
    drift = {k: v for k, v in found.items() if k not in UNRELATED}
    fields = field_defaults()
    assert not drift, "\n".join(
        f"{f}({p}={v!r}) but the config field's default is {fields[p]}"
        for (f, p), v in drift.items()
    )
    stale = set(UNRELATED) - set(found)
    assert not stale, f"UNRELATED lists what no longer differs: {sorted(stale)}"


def _example(
    signal: object, *, cutoff_hz: float = 6.0, butter_order: int = 5, gate: float | None = None
) -> None:
    """A drifted default (processing.cutoff_hz is 4 Hz) beside an equal one and a None."""


def test_a_drifted_default_is_found() -> None:
    found = drifted(iter([("example", _example)]), field_defaults())
    assert found == {("example", "cutoff_hz"): 6.0}
