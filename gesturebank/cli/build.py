"""`build-dataset` (also its own console script) and the summary it and `qc` print."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich import box
from rich.console import Console
from rich.padding import Padding
from rich.table import Table
from rich.text import Text

from gesturebank.app import NARROW_COLUMNS
from gesturebank.cli.options import (
    ConfigOption,
    QuietOption,
    SetOption,
    one_of,
    pick,
    resolve_config,
)
from gesturebank.cli.terminal import (
    EXIT_FAILED,
    EXIT_OK,
    EXIT_USAGE,
    missing_extras,
    user_errors,
)
from gesturebank.config import Executor
from gesturebank.errors import InputError
from gesturebank.extract.detectors import DETECTORS
from gesturebank.lift import LIFTERS

if TYPE_CHECKING:
    from gesturebank.app.build import BuildSummary
    from gesturebank.datasets.store import ClipRecord, TakeRecord


def build_dataset(
    inputs: Annotated[
        list[Path],
        typer.Argument(
            help="A folder of videos (searched recursively), or one or more video files.",
            metavar="VIDEOS...",
            show_default=False,
        ),
    ],
    *,
    out_dir: Annotated[Path, typer.Argument(help="Dataset folder to create or resume.")],
    config_file: ConfigOption = None,
    detector: Annotated[str | None, typer.Option(help=f"2D detector, {one_of(DETECTORS)}.")] = None,
    lifter: Annotated[str | None, typer.Option(help=f"3D lifter, {one_of(LIFTERS)}.")] = None,
    workers: Annotated[
        int | None, typer.Option(min=1, help="Takes built in parallel (default: CPU cores).")
    ] = None,
    executor: Annotated[
        Executor | None,
        typer.Option(parser=pick(Executor), help="'local' process pool (default) or 'ray'."),
    ] = None,
    ray_address: Annotated[
        str | None,
        typer.Option(
            help="Ray cluster: auto, HOST:PORT or ray://HOST:PORT (default: $RAY_ADDRESS, "
            "else start a local Ray)."
        ),
    ] = None,
    force: Annotated[bool, typer.Option(help="Rebuild takes that are already built.")] = False,
    no_cache: Annotated[
        bool, typer.Option("--no-cache", help="Run the detector even on videos seen before.")
    ] = False,
    quiet: QuietOption = False,
    sets: SetOption = None,
) -> None:
    """Build a dataset of Pepper angles and audio features from videos.

    Every video under the folder (or each video file given) becomes a take of aligned 100 Hz
    Pepper angles and audio features in OUT_DIR. Re-running resumes: built takes are skipped,
    and the QC thresholds and splits OUT_DIR was last judged with (see `gesturebank qc`) stay
    unless --config or --set change them.

    Exit code 0 when every take built, 1 when some failed (see the summary), 2 on a usage or
    configuration error.
    """
    from gesturebank.app.take import check_names
    from gesturebank.datasets.refresh import judged_with
    from gesturebank.datasets.takes import find_inputs

    with user_errors():
        config = resolve_config(
            config_file=config_file,
            sets=sets,
            flags={
                "detector": {"name": detector},
                "lifter": {"name": lifter},
                "build": {
                    "workers": workers,
                    "executor": executor,
                    "ray_address": ray_address,
                    "cache_detections": False if no_cache else None,
                },
            },
            base=judged_with(out_dir),
        )
        check_names(config)
        videos_dir, takes = find_inputs(inputs, config.build, out_dir=out_dir)
        if not takes:
            exts = ", ".join(config.build.video_extensions)
            raise InputError(f"{videos_dir}: no videos found ({exts})")
        ensure_writable(out_dir)
    from gesturebank.app.build import build_dataset as build
    from gesturebank.app.build import dashboard_after_build
    from gesturebank.app.progress import BuildProgress

    console = Console(quiet=quiet)
    with BuildProgress(takes, console) as progress, user_errors():
        summary = build(
            takes=takes,
            videos_dir=videos_dir,
            out=out_dir,
            config=config,
            force=force,
            on_result=progress.result,
            on_chunk=progress.chunk,
            on_frames=progress.frames,
        )
        summary = dashboard_after_build(summary)
    print_summary(console, summary)
    if summary.error:
        typer.echo(f"error: {summary.error}", err=True)
        raise typer.Exit(EXIT_USAGE)
    if summary.interrupted:
        raise typer.Exit(128 + summary.interrupted)  # the shell's code for death by that signal
    raise typer.Exit(EXIT_FAILED if summary.failed else EXIT_OK)


NARROW_HEADERS = {
    "takes built": "takes\nbuilt",
    "clips kept": "clips\nkept",
    "clips rejected": "clips\nrejected",
    "stretches dropped": "stretches\ndropped",
}


def print_summary(console: Console, summary: BuildSummary, *, built: bool = True) -> None:
    """The kept/rejected table and a line per take; `built` False: after `qc` (no build ran,
    so takes are counted, not built/skipped)."""
    narrow = console.width < NARROW_COLUMNS  # no vertical rules: the headers fit 80 columns
    table = (
        Table(
            title=f"dataset {summary.out}",
            box=box.SIMPLE_HEAD,
            pad_edge=False,
            collapse_padding=True,
        )
        if narrow
        else Table(title=f"dataset {summary.out}")
    )
    takes = ("takes built", "skipped", "failed") if built else ("takes", "failed")
    columns = (*takes, "clips kept", "clips rejected", "stretches dropped", "usable s", "seen s")
    for name in (*columns, "kept"):  # narrow: two-word headers on two lines, none cut
        table.add_column(NARROW_HEADERS.get(name, name) if narrow else name, justify="right")
    visible = summary.visible_s
    counts = (
        [str(summary.count(n)) for n in ("built", "skipped", "failed")]
        if built
        else [str(len(summary.takes)), str(sum(bool(r.failed) for r in summary.takes))]
    )
    n_dropped = sum(len(_dropped(r)) for r in summary.takes if not r.failed)
    table.add_row(
        *counts,
        *(str(summary.clip_count(s)) for s in ("accepted", "rejected")),
        str(n_dropped),
        f"{summary.usable_s:.1f}",
        f"{visible:.1f}",
        f"{summary.usable_s / visible:.0%}" if visible > 0 else "–",
    )
    console.print(table)
    for record in summary.takes:
        if record.failed:
            console.print(
                f"[red]failed[/red] {record.take_id}: {record.failed}",
                highlight=False,
                soft_wrap=not narrow,
            )
            continue
        kept = sum(c.qc_status == "accepted" for c in record.data_clips)
        rejected = [c for c in record.data_clips if c.qc_status != "accepted"]
        dropped = _dropped(record)
        stretches = "stretch" if len(dropped) == 1 else "stretches"
        if narrow:  # a block: the take's line, then its rejections and drops, wrapped at words
            console.print(
                f"{record.take_id}: {kept} of {len(record.data_clips)} clips kept, "
                f"{record.usable_s:.1f} of {record.visible_s:.1f} s usable",
                highlight=False,
            )
            for n, what, parts in (
                (len(rejected), "rejected", rejected),
                (len(dropped), f"{stretches} dropped", dropped),
            ):
                if n:
                    text = Text(f"{n} {what}{_why(parts)}")
                    console.print(Padding(text, (0, 0, 0, 2), expand=False), highlight=False)
            continue
        console.print(
            f"{record.take_id}: {kept} of {len(record.data_clips)} clips kept, "
            f"{len(rejected)} rejected{_why(rejected)}, "
            f"{len(dropped)} {stretches} dropped{_why(dropped)}; "
            f"{record.usable_s:.1f} of {record.visible_s:.1f} s",
            highlight=False,
            soft_wrap=True,
        )
    cached = sum(r.cached is True for r in summary.results)
    if built and cached:
        console.print(
            f"{cached} of {summary.count('built')} takes built took their detections from the "
            "cache (`gesturebank cache info`; --no-cache runs the detector again)",
            highlight=False,
            soft_wrap=not narrow,
        )
    for note in summary.notes:
        console.print(f"note: {note}", highlight=False, soft_wrap=not narrow)
    if summary.dashboard:
        console.print(f"QC dashboard: {summary.dashboard}", highlight=False, soft_wrap=True)
    if summary.interrupted:
        console.print("interrupted: finished takes are kept; run the same command to resume")


def _dropped(record: TakeRecord) -> list[ClipRecord]:
    """The spans of a built take that gave no clip (the dashboard's "dropped")."""
    return [c for c in record.clips if c.kind == "span" and c.qc_status != "failed"]


def _why(parts: list[ClipRecord]) -> str:
    """' (reason; reason)' of rejected clips or dropped stretches, each reason once."""
    reasons = sorted({r for c in parts for r in c.qc_reasons})
    return f" ({'; '.join(reasons)})" if reasons else ""


def ensure_writable(path: Path) -> None:
    """Create `path` if needed; InputError naming it when it cannot be written."""
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{path}: cannot create output folder ({exc.strerror})") from None
    if not path.is_dir() or not os.access(path, os.W_OK | os.X_OK):
        raise InputError(f"{path}: output folder is not writable")


def build_dataset_main() -> None:
    """Console script `build-dataset`: the same command as `gesturebank build-dataset`."""
    single = typer.Typer(
        add_completion=False, pretty_exceptions_enable=False, rich_markup_mode="markdown"
    )
    single.command()(build_dataset)
    with missing_extras():
        single(prog_name="build-dataset")
