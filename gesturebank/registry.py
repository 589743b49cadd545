"""Name → factory registries that third-party packages extend through entry points.

Detectors and lifters are looked up by name. Built-ins register themselves with the decorator;
a plug-in package declares e.g. `[project.entry-points."gesturebank.detectors"] mine = "pkg:Cls"`
and is found without touching gesturebank.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from importlib.metadata import entry_points
from typing import Any, Generic, TypeVar, cast

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
        return InputError(
            f"unknown {self.kind} {name!r}; available: {', '.join(self.names()) or 'none'}"
        )

    def create(self, name: str, *args: object, **kwargs: object) -> T:
        return self.get(name)(*args, **kwargs)
