"""`sim` backend: collects a playback's commands and renders them as an MP4 of Pepper in 3D
(`render.write_video`) with the audio muxed in.

The video shows the safety moves too (`render.ramps`): the start move from the neutral pose to
frame 0, the timeline with the audio (delayed by the start move, so it stays in sync), and the
return to neutral; each frame is captioned with the playback time and the move it shows.
Commands reach a backend already safe (limits, speed), so they are drawn as sent.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gesturebank.errors import InputError
from gesturebank.robot import pepper
from gesturebank.robot.backends import Command
from gesturebank.robot.render import write_video

if TYPE_CHECKING:
    from gesturebank.config import PlaybackConfig, RenderConfig

PathLike = str | os.PathLike[str]


class SimBackend:
    """Collects the commands of a playback; `close()` renders the timeline part to `out`."""

    name = "sim"
    realtime = False

    def __init__(
        self,
        out: PathLike,
        *,
        audio: PathLike | None = None,
        render: RenderConfig | None = None,
        start_pose: np.ndarray | None = None,
    ) -> None:
        self.out, self.audio, self.render = Path(out), audio, render
        if self.out.suffix.lower() != ".mp4":
            raise InputError(f"{self.out}: the sim backend writes .mp4 files")
        self.pose = np.asarray(pepper.neutral_pose() if start_pose is None else start_pose)
        self.commands: list[Command] = []
        self.video: Path | None = None

    @property
    def connected(self) -> bool:
        return True

    def get_angles(self) -> np.ndarray:
        return np.asarray(self.pose, np.float32).copy()

    def send(self, cmd: Command) -> None:
        self.commands.append(cmd)
        self.pose = cmd.angles

    def discard(self) -> None:
        """Forget the commands so far: `close` then writes no video (after an interrupted
        replay, whose truncated video would look complete)."""
        self.commands.clear()

    def close(self) -> None:
        from gesturebank.config import RenderConfig

        cfg = self.render or RenderConfig()
        body = [c for c in self.commands if c.phase in ("timeline", "live")]
        if not body or self.video is not None:
            return
        # live mode's start move runs on a clock of its own (t ≥ 0 before the live t = 0):
        # only moves before and after the body, on its clock, are drawn
        first, last = body[0].t, body[-1].t
        shown = [
            c
            for c in self.commands
            if c.phase in ("timeline", "live")
            or (cfg.ramps and (c.t < first if c.phase == "start" else c.t > last))
        ]
        times = np.array([c.t for c in shown])
        angles = np.stack([c.angles for c in shown])
        period = float(np.median(np.diff(times))) if len(times) > 1 else 0.01
        start = min(float(times[0]), 0.0)
        self.video = write_video(
            [("", times, angles)],
            self.out,
            duration=float(times[-1]) + period - start,
            audio=self.audio,
            render=cfg,
            start=start,
            timeline_end=float(body[-1].t) + period,
        )


def create(
    *,
    url: str | None = None,
    out: PathLike | None = None,
    audio: PathLike | None = None,
    config: PlaybackConfig | None = None,
    render: RenderConfig | None = None,
) -> SimBackend:
    """`render`: the look of the video (default: `RenderConfig()`)."""
    if out is None:
        raise InputError("--backend sim needs --out VIDEO.mp4")
    return SimBackend(out, audio=audio, render=render)
