"""`gesturebank cache info|clear`: the detection cache (`extract.cache`), where it is and what it
holds. Builds reuse a video's detections from it (same video content, same detector settings),
so a rebuild with another lifter or other filters skips the detector."""

from __future__ import annotations

import os

import typer

from gesturebank.cli.terminal import out, user_errors

cache_app = typer.Typer(
    help="The detection cache: where it is, its size (info), emptying it (clear).",
    no_args_is_help=True,
)


def _size(n_bytes: int) -> str:
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("KB", 1e3)):
        if n_bytes >= scale:
            return f"{n_bytes / scale:.1f} {unit}"
    return f"{n_bytes} B"


@cache_app.command("info")
def cache_info() -> None:
    """Where the detection cache is (the user cache dir, or $GESTUREBANK_CACHE), how many
    entries it holds and their size."""
    from gesturebank.extract.cache import ENV, DetectionCache

    with user_errors():
        cache = DetectionCache()
        entries = cache.entries()
        total = sum(e.stat().st_size for e in entries)
    where = f"set by ${ENV}" if ENV in os.environ else f"the default place; ${ENV} moves it"
    # the path on a line of its own, whole (to copy), what it is below: 80 columns fit
    out.print(f"detection cache: {cache.root}", highlight=False, soft_wrap=True)
    out.print(f"  {where}", highlight=False)
    noun = "entry" if len(entries) == 1 else "entries"
    out.print(f"{len(entries)} {noun}, {_size(total)}", highlight=False)


@cache_app.command("clear")
def cache_clear() -> None:
    """Remove every cached detection; the next build of those videos runs the detector again."""
    from gesturebank.extract.cache import DetectionCache

    with user_errors():
        cache = DetectionCache()
        removed, freed = cache.clear()
    out.print(
        f"removed {removed} {'entry' if removed == 1 else 'entries'} ({_size(freed)}) from "
        f"{cache.root}",
        highlight=False,
        soft_wrap=True,
    )
