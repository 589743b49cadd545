"""`sim` backend: collects a playback's commands and renders the timeline part as an MP4
(`render.write_video`) with the audio muxed in.

The video covers the timeline (playback clock 0 → its end); the safety moves before and after it
are not drawn. Commands reach a backend already safe (limits, speed), so they are drawn as sent.
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
    from gesturebank.config import PlaybackConfig

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
        fps: int = 25,
        view_px: int = 360,
        start_pose: np.ndarray | None = None,
    ) -> None:
        self.out, self.audio, self.fps, self.view_px = Path(out), audio, fps, view_px
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
        shown = [c for c in self.commands if c.phase in ("timeline", "live")]
        if not shown or self.video is not None:
            return
        times = np.array([c.t for c in shown])
        angles = np.stack([c.angles for c in shown])
        period = float(np.median(np.diff(times))) if len(times) > 1 else 0.01
        self.video = write_video(
            [("", times, angles)],
            self.out,
            duration=float(times[-1]) + period,
            audio=self.audio,
            fps=self.fps,
            view_px=self.view_px,
        )


def create(
    *,
    url: str | None = None,
    out: PathLike | None = None,
    audio: PathLike | None = None,
    config: PlaybackConfig | None = None,
) -> SimBackend:
    if out is None:
        raise InputError("--backend sim needs --out VIDEO.mp4")
    if config is None:
        return SimBackend(out, audio=audio)
    return SimBackend(out, audio=audio, fps=config.sim_fps, view_px=config.sim_view_px)
