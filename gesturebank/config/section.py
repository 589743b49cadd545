"""The base of every config section: unknown keys are errors, and values are validated on
assignment too. `PluginSections` is the base of a plug-in kind's section (`[detector]`,
`[lifter]`): its `name` chooses one, and each plug-in's own settings are its sub-section
`[KIND.NAME]`, a field for a built-in, validated by the plug-in's `section_model` otherwise.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from typing import Any, ClassVar

from pydantic import BaseModel, ConfigDict, model_validator
from pydantic_core import PydanticCustomError

from gesturebank.errors import GesturebankDeprecationWarning
from gesturebank.registry import plugin_default, plugin_section


class Section(BaseModel):
    """A config section: unknown keys are errors, values are validated on assignment too."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=False)


class PluginSections(Section):
    """`[KIND]` with `name` and one sub-section `[KIND.NAME]` per plug-in: a built-in's is a field
    (named with `_` for `-`), another must be a plug-in's of the entry-point group `plugin_group`,
    validated by it (`registry.plugin_section`)."""

    model_config = ConfigDict(
        extra="allow", validate_assignment=True, frozen=False, populate_by_name=True
    )
    plugin_group: ClassVar[str]
    name: str

    @model_validator(mode="after")
    def _plugin_sections(self) -> PluginSections:
        extra = self.__pydantic_extra__ or {}
        for name, raw in extra.items():
            if isinstance(raw, BaseModel):  # already validated (a copy, an assignment)
                continue
            try:
                extra[name] = plugin_section(
                    self.plugin_group, name, raw=raw, known=type(self).model_fields
                )
            except ValueError as exc:  # one line, at the [KIND] table: "NAME.key: problem"
                raise PydanticCustomError("plugin_section", "{why}", {"why": str(exc)}) from None
        return self

    def settings(self, name: str | None = None) -> BaseModel | None:
        """The own settings of plug-in `name` (default: the chosen one): a built-in's field, a
        plug-in's validated section (its defaults when not written), None when it has none."""
        name = self.name if name is None else name
        field = name.replace("-", "_")
        if field in type(self).model_fields and field != "name":
            value = getattr(self, field)
            return value if isinstance(value, BaseModel) else None
        found = (self.model_extra or {}).get(name)
        return found if found is not None else plugin_default(self.plugin_group, name)


def deprecated_key(old: str, new: str) -> None:
    """Warn once that the config key `old` is read for one more release as `new`."""
    warnings.warn(
        f"config key {old} is deprecated: use {new} (read for this release only)",
        GesturebankDeprecationWarning,
        stacklevel=3,
    )


def nest(data: Mapping[str, Any], key: str, *, values: Mapping[str, Any]) -> dict[str, Any]:
    """`data` with the mapping `values` merged under `key` (values already there win)."""
    out = dict(data)
    out[key] = {**values, **dict(out.get(key) or {})}
    return out
