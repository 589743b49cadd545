"""The robot commands' work: the side-by-side video of several timelines (`replay --compare`)
and a model folder readied for live mode."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gesturebank.config import PlaybackConfig, RenderConfig
from gesturebank.errors import InputError
from gesturebank.robot import pepper

if TYPE_CHECKING:
    from gesturebank.robot.online import LiveModel
    from gesturebank.robot.timeline import Timeline

PathLike = str | os.PathLike[str]


def side_by_side(
    timelines: list[Timeline],
    *,
    labels: list[str],
    out: PathLike,
    profile: pepper.RobotProfile,
    audio: PathLike | None,
    config: PlaybackConfig,
    render: RenderConfig | None = None,
) -> Path:
    """The timelines played as replay plays them (start move, safe timeline, return move — on
    the sim backend's virtual clock), rendered next to each other with their labels for as long
    as the longest; without `render.ramps` only the timelines, from 0 s."""
    from gesturebank.robot.backends.sim import SimBackend
    from gesturebank.robot.playback import play
    from gesturebank.robot.render import write_video  # PyAV and OpenCV: only when rendering

    cfg = render or RenderConfig()
    tracks, starts, ends = [], [], []
    for tl, lab in zip(timelines, labels, strict=True):
        collector = SimBackend(Path(out), render=cfg)  # collects the commands; never closed
        play(tl, collector, config=config, profile=profile)
        shown = [c for c in collector.commands if cfg.ramps or c.phase == "timeline"]
        times = np.array([c.t for c in shown])
        tracks.append((lab, times, np.stack([c.angles for c in shown])))
        starts.append(min(float(times[0]), 0.0))
        ends.append(float(times[-1]) + tl.period)
    start = min(starts)
    return write_video(
        tracks,
        out,
        duration=max(ends) - start,
        audio=audio,
        render=cfg,
        start=start,
        timeline_end=max(tl.end for tl in timelines),
    )


def load_frame_model(model_dir: PathLike, znorm: str = "*") -> LiveModel:
    """The model folder written by `gesturebank train` (`train.model_folder`), ready for live use:
    its ONNX graph stepped one frame at a time (`train.model_folder.OnnxFrameModel`). Only
    causal models run live (model.json's "causal"); the others need future audio and are refused
    in one line (offline `synthesize` plays them).

    znorm: whose audio statistics normalise the live features — "*" (the whole dataset) or a
    subject of the training data.
    """
    from gesturebank.robot.online import LiveModel
    from gesturebank.train import model_folder

    folder = model_folder.load(model_dir)
    if not folder.causal:
        kind = (folder.info.architecture or {}).get("kind", "?")
        raise InputError(
            f"{folder.path}: model {kind!r} is not causal (it needs future audio), so it cannot "
            "run live; play it offline with `gesturebank synthesize`"
        )
    mean, std = folder.znorm(znorm)
    model = model_folder.OnnxFrameModel(folder.graph)
    target = folder.info.target
    flag = 1 if target == "listener" else 0  # a listener also takes the speaking flag
    if model.n_features is not None and model.n_features != len(mean) + flag:
        raise InputError(
            f"{folder.graph}: model takes {model.n_features} features, normalisers have {len(mean)}"
            + (" (+ the speaking flag)" if flag else "")
        )
    return LiveModel(
        model, mean, std, folder.profile, folder.audio, folder.info.reach, listener=bool(flag)
    )
