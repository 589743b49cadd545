"""The options several commands share, defined once, and how a command resolves its config."""

from __future__ import annotations

import difflib
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, Literal, get_args

import typer

from gesturebank.config import Config, load_config, parse_override
from gesturebank.registry import Registry
from gesturebank.robot.backends import BACKENDS


def one_of(registry: Registry[Any]) -> str:
    """The names a registry knows (plug-ins too), for a help text."""
    return "one of: " + ", ".join(registry.names())


def did_you_mean(name: str, names: list[str] | tuple[str, ...]) -> str:
    """ "; did you mean 'lstm'?" for the closest of `names`, or ''."""
    close = difflib.get_close_matches(name, list(names), n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def pick(choices: Any) -> Callable[[str], str]:
    """An option's parser for a Literal of names: a wrong one is a usage error naming the flag
    (click adds it), the valid values and the closest ("did you mean")."""
    values: tuple[str, ...] = get_args(choices)

    def parse(value: str) -> str:
        if value in values:
            return value
        raise typer.BadParameter(
            f"{value!r} is not one of {', '.join(values)}{did_you_mean(value, values)}"
        )

    return parse


# Options shared by several commands, defined once.
ConfigOption = Annotated[
    Path | None,
    typer.Option("--config", "-c", help="TOML config file (see `gesturebank config`)."),
]
SetOption = Annotated[
    list[str] | None,
    typer.Option(
        "--set", help="Override one config key, e.g. --set processing.cutoff_hz=6 (repeatable)."
    ),
]
QuietOption = Annotated[bool, typer.Option("--quiet", "-q", help="No progress output.")]
ForceOption = Annotated[
    bool, typer.Option("--force", help="Replace an output that exists (else it is kept: exit 2).")
]
ModelDirArg = Annotated[Path, typer.Argument(help="A model folder written by `train`.")]
DatasetArg = Annotated[Path, typer.Argument(help="A dataset folder written by build-dataset.")]
# a registry, not a Literal: plug-in backends are valid too
BackendOption = Annotated[
    str, typer.Option(help=f"{one_of(BACKENDS)} (naoqi: a robot, sim: an MP4, record: JSONL).")
]
OutFileOption = Annotated[
    Path | None,
    typer.Option(
        "--out", help="sim: video.mp4; record: calls.jsonl, or timeline.csv (an angle timeline)."
    ),
]
SplitPart = Literal["test", "val", "train"]
Status = Literal["accepted", "rejected"]  # a clip's QC verdict (datasets.store.STATUSES)


def resolve_config(
    *,
    config_file: Path | None,
    sets: list[str] | None,
    flags: dict[str, dict[str, Any]],
    base: Config | None = None,
) -> Config:
    """Defaults (or `base`) < config file < --set KEY=VALUE < dedicated flags (those given)."""
    overrides = [parse_override(s) for s in sets or []]
    given = {sec: {k: v for k, v in keys.items() if v is not None} for sec, keys in flags.items()}
    overrides.append({sec: keys for sec, keys in given.items() if keys})
    return load_config(config_file, overrides, base=base)
