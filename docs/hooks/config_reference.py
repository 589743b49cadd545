"""mkdocs hook: the configuration reference, generated from the pydantic models at build time.

`docs/configuration.md` holds the marker `<!-- config-reference -->`; this hook replaces it with
one table per section of `gesturebank.config.Config` (nested sections such as `[train.mlp]`
get their own), each key with its type, default, unit, allowed range and description as the
field declares them. Nothing is copied by hand, so the page cannot fall behind the code.
`tests/test_docs.py` reads the same tables.
"""

from __future__ import annotations

import types
import typing
from typing import Any

import annotated_types
from pydantic import BaseModel
from pydantic.fields import FieldInfo

MARKER = "<!-- config-reference -->"
PAGE = "configuration.md"

# The unit a key's name ends with (the project names quantities with their unit).
UNIT_SUFFIXES = {
    "_s": "s",
    "_hz": "Hz",
    "_m": "m",
    "_deg": "°",
    "_px": "px",
    "_mps2": "m/s²",
    "_mb": "MB",
    "_kb": "kB",
    "_frames": "frames",
    "_fraction": "share 0–1",
}

_BOUNDS = (
    (annotated_types.Ge, "≥", "ge"),
    (annotated_types.Gt, ">", "gt"),
    (annotated_types.Le, "≤", "le"),
    (annotated_types.Lt, "<", "lt"),
)


def unit_of(key: str) -> str:
    """The unit a key's name says ('max_gap_s' → 's'), '' when it says none."""
    for suffix, unit in UNIT_SUFFIXES.items():
        if key.endswith(suffix):
            return unit
    return ""


def type_name(annotation: Any) -> str:
    """A TOML reader's name for a field's type: `float | None` → 'float or none'."""
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin is typing.Literal:
        return " \\| ".join(f"`{a!r}`" for a in args)
    if origin in (typing.Union, types.UnionType):
        names = [type_name(a) for a in args if a is not type(None)]
        return " or ".join(names) + (" or none" if type(None) in args else "")
    if origin in (list, tuple, dict):
        inner = ", ".join(type_name(a) for a in args if a is not Ellipsis)
        return f"{origin.__name__}[{inner}]"
    return getattr(annotation, "__name__", str(annotation))


def toml_value(value: Any) -> str:
    """A default as one would write it in gesturebank.toml (`none` where TOML has no null)."""
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"
    return repr(value)


def default_of(field: FieldInfo) -> Any:
    if field.default_factory is not None:
        return field.default_factory()  # type: ignore[call-arg]
    return field.default


def bounds_of(field: FieldInfo) -> str:
    """'≥ 0, ≤ 1' from the field's constraints ('' when it has none)."""
    found = []
    for meta in field.metadata:
        for kind, sign, attr in _BOUNDS:
            if isinstance(meta, kind):
                found.append(f"{sign} {getattr(meta, attr)}")
    return ", ".join(found)


def _cell(text: str) -> str:
    """Text safe inside a Markdown table cell (no column breaks, no stray HTML or emphasis)."""
    for raw, safe in (("|", "\\|"), ("<", "&lt;"), (">", "&gt;"), ("*", "\\*"), ("\n", " ")):
        text = text.replace(raw, safe)
    return text


def _is_section(annotation: Any) -> bool:
    return isinstance(annotation, type) and issubclass(annotation, BaseModel)


def _doc(model: type[BaseModel]) -> str:
    doc = model.__dict__.get("__doc__") or ""
    return " ".join(doc.split())


def section_tables(model: type[BaseModel], prefix: str = "") -> list[str]:
    """Markdown for `model`'s own keys under the heading `[prefix]`, then its nested sections."""
    out: list[str] = []
    leaves = []
    nested = []
    for name, field in model.model_fields.items():
        key = field.alias or name  # as written in TOML: [detector.openpose-json]
        (nested if _is_section(field.annotation) else leaves).append((key, field))
    if prefix:
        out.append(f"### `[{prefix}]`\n")
        if _doc(model):
            out.append(_cell(_doc(model)) + "\n")
    if leaves:
        out.append("| key | type | default | unit | allowed | description |")
        out.append("|---|---|---|---|---|---|")
        for key, field in leaves:
            cells = (
                f"`{key}`",
                type_name(field.annotation),
                f"`{toml_value(default_of(field))}`",
                unit_of(key),
                bounds_of(field),
                _cell(field.description or ""),
            )
            out.append("| " + " | ".join(cells) + " |")
        out.append("")
    for key, field in nested:
        out.extend(section_tables(field.annotation, f"{prefix}.{key}" if prefix else key))
    return out


def reference() -> str:
    """The whole reference: every section of `Config`, in the order the model declares them."""
    from gesturebank.config import Config

    return "\n".join(section_tables(Config))


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    if page.file.src_uri != PAGE:
        return markdown
    if MARKER not in markdown:
        from mkdocs.exceptions import PluginError

        raise PluginError(f"docs/{PAGE}: the marker {MARKER} is missing")
    return markdown.replace(MARKER, reference())
