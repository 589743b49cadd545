"""`gesturebank clips` and `preview`: what a dataset holds, clip by clip."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from gesturebank.cli.options import (
    ConfigOption,
    DatasetArg,
    ForceOption,
    SetOption,
    Status,
    pick,
    resolve_config,
)
from gesturebank.cli.terminal import out, user_errors
from gesturebank.fileio import keep_existing


def preview(
    dataset: DatasetArg,
    *,
    out_path: Annotated[
        Path, typer.Option("--out", help="--clip: the MP4 to write; --take: a folder for them.")
    ],
    clip: Annotated[str | None, typer.Option(help="The clip to show.")] = None,
    take: Annotated[str | None, typer.Option(help="Every clip of this take, one MP4 each.")] = None,
    config_file: ConfigOption = None,
    sets: SetOption = None,
    force: ForceOption = False,
) -> None:
    """A clip's speaker beside the robot doing the same, on one clock, with the clip's audio.

    Left: the source video cropped to the speaker, their 2D keypoints drawn. Right: the robot as
    `replay --clip --backend sim` shows the clip ([render] sets the size and frame rate). The
    strip of black and white squares in each half's bottom-left corner is a frame code (its
    legend beside it: "< video frame N", "< clip frame N"), the source frame and the clip frame
    shown, readable back by `datasets.preview.read_frame_code`.
    """
    from gesturebank.app.preview import preview_command

    with user_errors():
        keep_existing([out_path], force=force)
        config = resolve_config(config_file=config_file, sets=sets, flags={})
        written = preview_command(dataset, clip=clip, take=take, out=out_path, config=config)
    for path in written:
        out.print(f"wrote {path}", highlight=False, soft_wrap=True)


def clips(
    out_dir: DatasetArg,
    *,
    status: Annotated[
        Status | None,
        typer.Option(parser=pick(Status), help="Only clips the QC accepted or rejected."),
    ] = None,
    subject: Annotated[str | None, typer.Option(help="Only this subject's clips.")] = None,
    take: Annotated[str | None, typer.Option(help="Only this take's clips.")] = None,
    as_csv: Annotated[
        bool, typer.Option("--csv", help="CSV on stdout instead of a table.")
    ] = False,
) -> None:
    """List a dataset's clips: id, take, subject, where in the source video (start–end, s),
    seconds, QC status and reasons, and the body parts unknown in some frames (masked). A
    terminal narrower than 120 columns gets one block per clip instead of a table.

    A clip id (or a take id, when the take has one clip) is what `replay OUT_DIR --clip` takes.
    """
    from gesturebank import datasets
    from gesturebank.app.clip_list import clips_view
    from gesturebank.datasets.listing import list_clips, rows_csv

    with user_errors():
        rows = list_clips(datasets.open(out_dir), status=status, subject=subject, take=take)
    if as_csv:
        typer.echo(rows_csv(rows), nl=False)
        return
    title = f"{out_dir}: {len(rows)} clip{'' if len(rows) == 1 else 's'}"
    out.print(clips_view(rows, title=title, width=out.width))
