"""`gesturebank preview`'s work: a clip's or a take's preview videos (`datasets.preview`) with
the [render] and [playback] sections and the robot profile of the resolved config."""

from __future__ import annotations

import os
from pathlib import Path

from gesturebank.config import Config
from gesturebank.datasets.preview import preview_clip, preview_take
from gesturebank.errors import InputError

PathLike = str | os.PathLike[str]


def preview_command(
    dataset: PathLike, *, clip: str | None, take: str | None, out: PathLike, config: Config
) -> list[Path]:
    """`gesturebank preview DATASET (--clip ID | --take ID) --out PATH`: the videos written."""
    render, playback, profile = config.render, config.playback, config.robot.profile
    if clip is not None and take is None:
        return [
            preview_clip(
                dataset, clip_id=clip, out=out, render=render, playback=playback, profile=profile
            )
        ]
    if take is not None and clip is None:
        return preview_take(
            dataset, take_id=take, out_dir=out, render=render, playback=playback, profile=profile
        )
    raise InputError("preview: give --clip ID or --take ID (one of them)")
