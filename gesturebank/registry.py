"""Name → factory registries that third-party packages extend through entry points.

Detectors and lifters are looked up by name. Built-ins register themselves with the decorator;
a plug-in package declares e.g. `[project.entry-points."gesturebank.detectors"] mine = "pkg:Cls"`
and is found without touching gesturebank.
"""

from __future__ import annotations

import difflib
import importlib
from collections.abc import Callable, Iterable
from importlib.metadata import entry_points
from typing import Any, Generic, TypeVar, cast

from pydantic import BaseModel, ValidationError

from gesturebank.errors import InputError

T = TypeVar("T")


class Registry(Generic[T]):
    """Factories of one kind of stage, by name; entry points of `group` are loaded on demand."""

    def __init__(self, kind: str, group: str) -> None:
        self.kind = kind
        self.group = group
        self._factories: dict[str, Callable[..., T]] = {}
        self._lazy: dict[str, str] = {}  # name → "module:attribute", imported on first use

    def register(self, name: str) -> Callable[[Callable[..., T]], Callable[..., T]]:
        def add(factory: Callable[..., T]) -> Callable[..., T]:
            self._factories[name] = factory
            return factory

        return add

    def register_lazy(self, name: str, target: str) -> None:
        """Register "module:attribute" (or "module:Class.method"), imported only when `name` is
        first used, so listing the names never imports heavy dependencies (mediapipe, torch)."""
        self._lazy[name] = target

    def _plugins(self) -> dict[str, object]:
        return {ep.name: ep for ep in entry_points(group=self.group)}

    def names(self) -> list[str]:
        """Built-in and plug-in names, sorted."""
        return sorted(set(self._factories) | set(self._lazy) | set(self._plugins()))

    def get(self, name: str) -> Callable[..., T]:
        """The factory registered as `name`; InputError listing the known names otherwise."""
        if name in self._factories:
            return self._factories[name]
        if name in self._lazy:
            module, _, attr = self._lazy[name].partition(":")
            real: Any = importlib.import_module(module)
            for part in attr.split("."):  # "Class.from_config", as entry points allow
                real = getattr(real, part)
            self._factories[name] = real  # the object itself: its signature can be inspected
            return cast(Callable[..., T], real)
        plugin = self._plugins().get(name)
        if plugin is None:
            raise self._unknown(name)
        try:
            factory = plugin.load()  # type: ignore[attr-defined]
        except Exception as exc:  # a broken plug-in must not look like a missing one
            raise InputError(f"{self.kind} plug-in {name!r} failed to load: {exc}") from exc
        self._factories[name] = factory
        return factory

    def check(self, name: str) -> None:
        """InputError, as `get` raises it, when `name` is not registered; imports nothing, so a
        command can check its names before any work starts."""
        if name not in self.names():
            raise self._unknown(name)

    def _unknown(self, name: str) -> InputError:
        """The error for an unknown name: the flag, the names, the closest."""
        names = self.names()
        flag = f"--{self.kind.split()[-1]}"  # "robot backend" → --backend
        close = difflib.get_close_matches(name, names, n=1, cutoff=0.6)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        known = f"one of: {', '.join(names)}" if names else "none is registered"
        return InputError(f"unknown {self.kind} {name!r} ({flag}); {known}{hint}")

    def create(self, name: str, *args: object, **kwargs: object) -> T:
        return self.get(name)(*args, **kwargs)


def section_model_of(factory: object) -> type[BaseModel] | None:
    """The pydantic model of a plug-in's own section: `section_model` of its class (a factory
    "Class.from_config" is looked up on its class), None when it declares none."""
    owner = getattr(factory, "__self__", factory)  # a bound classmethod: its class
    section = getattr(owner, "section_model", None)  # e.g. `train.contract.OwnSection`
    return section if isinstance(section, type) and issubclass(section, BaseModel) else None


def plugin_default(group: str, name: str) -> BaseModel | None:
    """The default section of plug-in `name` of `group` (its `section_model()`), None when it is
    no plug-in or declares no section."""
    plugin = {ep.name: ep for ep in entry_points(group=group)}.get(name)
    if plugin is None:
        return None
    try:
        section = section_model_of(plugin.load())
    except Exception:  # a broken plug-in fails where it is created, with its own message
        return None
    return None if section is None else section()


def plugin_section(group: str, name: str, *, raw: object, known: Iterable[str]) -> BaseModel:
    """A plug-in's own config section `NAME` (`[train.NAME]` of a "gesturebank.models" plug-in,
    `[detector.NAME]`, `[lifter.NAME]`), validated by the `section_model` (a pydantic model)
    its class declares.

    ValueError, one line "NAME: …" or "NAME.key: …", when `name` is no plug-in of `group` (with
    the nearest of the `known` keys), the plug-in declares no section, or a value is wrong.
    """
    plugins = {ep.name: ep for ep in entry_points(group=group)}
    plugin = plugins.get(name)
    if plugin is None:
        close = difflib.get_close_matches(name, [*known, *plugins], n=1, cutoff=0.6)
        raise ValueError(f"{name}: unknown key" + (f" (did you mean {close[0]}?)" if close else ""))
    try:
        owner = plugin.load()
    except Exception as exc:  # a broken plug-in must not look like a missing one
        raise ValueError(f"{name}: plug-in {plugin.value} failed to load ({exc})") from exc
    section = section_model_of(owner)
    if section is None:
        raise ValueError(f"{name}: plug-in {plugin.value} declares no section_model")
    try:
        return section.model_validate(raw)
    except ValidationError as exc:
        err = exc.errors()[0]
        key = ".".join([name, *(str(p) for p in err["loc"])])
        why = "unknown key" if err["type"] == "extra_forbidden" else err["msg"]
        raise ValueError(f"{key}: {why}") from None
