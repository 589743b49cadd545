"""Build, describe and rebuild any registered model (`train.registry.MODELS`).

A model's architecture is derived, not hand-written: the keyword parameters of its constructor
(after `n_features`), each read from the first of its `config_sections` that has a key of that
name. model.json's "architecture" is `{"kind", "n_features", those parameters in constructor
order}`; `from_architecture` validates each value with its config field's type and rebuilds the
same module.
"""

from __future__ import annotations

import inspect
import weakref
from typing import Any, cast

from pydantic import BaseModel, TypeAdapter, ValidationError
from torch import nn

from gesturebank.config import TrainConfig
from gesturebank.errors import InputError
from gesturebank.train.contract import OwnSection, SpeechToMotion
from gesturebank.train.registry import MODELS

# The architecture each module was built from, kept beside it (not on it: a model may have an
# attribute of that name).
_BUILT: weakref.WeakKeyDictionary[nn.Module, dict[str, Any]] = weakref.WeakKeyDictionary()


def section_model(model: type[SpeechToMotion], name: str) -> type[BaseModel]:
    """The pydantic model of `[train.NAME]`: a built-in's field, or a plug-in's `section_model`."""
    field = TrainConfig.model_fields.get(name)
    if field is not None and isinstance(field.annotation, type):
        return field.annotation
    if name == model.kind and isinstance(model, OwnSection):
        return model.section_model
    raise InputError(f"model {model.kind!r}: no config section [train.{name}]")


def section(config: TrainConfig, model: type[SpeechToMotion], *, name: str) -> BaseModel:
    """The values of `[train.NAME]` in `config` (a plug-in's defaults when it is absent)."""
    if name in TrainConfig.model_fields:
        value: BaseModel = getattr(config, name)
        return value
    own = (config.model_extra or {}).get(name)  # validated by `TrainConfig` (config.py)
    return own if isinstance(own, BaseModel) else section_model(model, name)()


def _parameters(model: type[SpeechToMotion]) -> list[tuple[str, str]]:
    """(parameter, the section it is read from) for the constructor's parameters after
    `n_features`, in order."""
    names = list(inspect.signature(model).parameters)[1:]
    out = []
    for name in names:
        where = next(
            (s for s in model.config_sections if name in section_model(model, s).model_fields),
            None,
        )
        if where is None:
            sections = ", ".join(f"[train.{s}]" for s in model.config_sections)
            raise InputError(f"model {model.kind!r}: parameter {name!r} is in none of {sections}")
        out.append((name, where))
    return out


def model_class(kind: str) -> type[SpeechToMotion]:
    """The registered model class `kind`; InputError when it does not keep the contract."""
    cls = MODELS.get(kind)
    # a Protocol with data members cannot be checked on a class: the trainer checks an instance
    if not (
        isinstance(cls, type) and issubclass(cls, nn.Module) and hasattr(cls, "config_sections")
    ):
        raise InputError(f"model {kind!r}: not a speech-to-motion model class (train.contract)")
    return cast(type[SpeechToMotion], cls)


def build_model(kind: str, n_features: int, *, config: TrainConfig) -> nn.Module:
    """A freshly initialised model named `kind` (a `MODELS` name) for `n_features` inputs."""
    cls = model_class(kind)
    arch: dict[str, Any] = {"kind": cls.kind, "n_features": n_features}
    for name, where in _parameters(cls):
        arch[name] = getattr(section(config, cls, name=where), name)
    return _construct(cls, arch)


def architecture(model: nn.Module) -> dict[str, Any]:
    """Plain data from which `from_architecture` rebuilds the same module (model.json's)."""
    arch = _BUILT.get(model)
    if arch is None:
        raise InputError(f"{type(model).__name__}: not built by build_model or from_architecture")
    return dict(arch)


def from_architecture(arch: dict[str, Any]) -> nn.Module:
    """The module model.json's "architecture" describes, freshly initialised."""
    cls = model_class(str(arch["kind"]))
    values: dict[str, Any] = {"kind": cls.kind, "n_features": int(arch["n_features"])}
    for name, where in _parameters(cls):
        if name not in arch:
            raise InputError(f"model {cls.kind!r}: architecture without {name!r}")
        annotation = section_model(cls, where).model_fields[name].annotation
        try:
            values[name] = TypeAdapter(annotation or Any).validate_python(arch[name])
        except ValidationError as exc:
            reason = exc.errors()[0]["msg"]
            raise InputError(f"model {cls.kind!r}: architecture {name}: {reason}") from None
    return _construct(cls, values)


def _construct(cls: type[SpeechToMotion], arch: dict[str, Any]) -> nn.Module:
    parameters = {k: v for k, v in arch.items() if k not in ("kind", "n_features")}
    net: Any = cls(arch["n_features"], **parameters)  # type: ignore[call-arg]
    _BUILT[net] = arch
    module: nn.Module = net
    return module


def n_parameters(model: nn.Module) -> int:
    return sum(p.numel() for p in model.parameters())
