"""The `replay` and `live` commands, as plain functions for the CLI to wrap."""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gesturebank.config import AudioConfig, PlaybackConfig, RobotConfig
from gesturebank.errors import RobotError
from gesturebank.robot import pepper
from gesturebank.robot.audio_out import DeviceAudio
from gesturebank.robot.backends import create
from gesturebank.robot.playback import PlaybackResult, play
from gesturebank.robot.safety import check_timeline, safe_angles, speed_profile
from gesturebank.robot.timeline import Timeline, from_clip, read_csv

if TYPE_CHECKING:
    from gesturebank.robot.online import Chunks, LiveResult

log = logging.getLogger(__name__)

PathLike = str | os.PathLike[str]


def replay_command(
    angles_csv: PathLike,
    backend: str,
    url: str | None = None,
    out: PathLike | None = None,
    audio: PathLike | None = None,
    config: PlaybackConfig | None = None,
    *,
    clip: str | None = None,
    compare: PathLike | None = None,
    profile: str | None = None,
    clamp: bool = False,
) -> PlaybackResult | Path:
    """`gesturebank replay ANGLES.csv --backend naoqi|sim|record [--url|--out] [--audio]`.

    `clip`: read the timeline from that clip of the dataset folder `angles_csv` instead.
    `compare` (sim only): a second timeline CSV rendered side by side; returns the video path.
    `clamp`: play timelines far outside the limits clamped instead of refusing them.
    An interrupted sim replay writes no video.
    """
    cfg = config or PlaybackConfig()
    robot = pepper.load_profile(profile or RobotConfig().profile)
    timeline = from_clip(angles_csv, clip) if clip else read_csv(angles_csv)
    name = f"{os.fspath(angles_csv)} clip {clip}" if clip else os.fspath(angles_csv)
    check_timeline(timeline, name=name, profile=robot, config=cfg, clamp=clamp)
    if compare is not None:
        if backend != "sim" or out is None:
            raise RobotError("--compare needs --backend sim and --out VIDEO.mp4")
        other = read_csv(compare)
        check_timeline(other, name=os.fspath(compare), profile=robot, config=cfg, clamp=clamp)
        return _side_by_side(
            [timeline, other],
            [Path(angles_csv).stem, Path(compare).stem],
            out,
            profile=speed_profile(robot, cfg.max_speed_fraction),
            audio=audio,
            config=cfg,
        )
    be = create(backend, url=url, out=out, audio=audio, config=cfg)
    try:
        sound = DeviceAudio(audio) if audio is not None and be.realtime else None
        result = play(timeline, be, config=cfg, profile=robot, audio=sound)
        if result.status == "interrupted" and be.name == "sim":
            from gesturebank.robot.backends.sim import SimBackend

            if isinstance(be, SimBackend):
                be.discard()  # its video would end early, yet look complete
    finally:
        be.close()
    p50, p99 = result.timing_ms()
    log.info(
        "%s: %d frames %s on %s (%s); send timing p50 %.2f ms, p99 %.2f ms",
        os.fspath(angles_csv),
        result.n_frames,
        result.status,
        backend,
        result.mode,
        p50,
        p99,
    )
    return result


def _side_by_side(
    timelines: list[Timeline],
    labels: list[str],
    out: PathLike,
    *,
    profile: pepper.RobotProfile,
    audio: PathLike | None,
    config: PlaybackConfig,
) -> Path:
    """The timelines, made safe as playback makes them (clamp + speed), rendered next to each
    other for as long as the longest."""
    from gesturebank.robot.render import write_video  # PyAV and OpenCV: only when rendering

    tracks = [
        (lab, tl.times, safe_angles(tl, profile)) for tl, lab in zip(timelines, labels, strict=True)
    ]
    duration = max(tl.end for tl in timelines)
    return write_video(
        tracks,
        out,
        duration=duration,
        audio=audio,
        fps=config.sim_fps,
        view_px=config.sim_view_px,
    )


def live_command(
    model_dir: PathLike,
    backend: str,
    input: str = "mic",
    url: str | None = None,
    out: PathLike | None = None,
    config: PlaybackConfig | None = None,
    *,
    audio_config: AudioConfig | None = None,
    max_seconds: float | None = None,
    znorm: str = "*",
) -> LiveResult:
    """`gesturebank live MODEL_DIR --backend naoqi|sim|record [--input mic|FILE.wav]`."""
    # imported here: the audio-feature stack costs seconds that `replay` need not wait
    from gesturebank.robot.online import (
        LiveSynth,
        load_frame_model,
        mic_chunks,
        run_live,
        wav_chunks,
    )

    cfg = config or PlaybackConfig()
    model = load_frame_model(model_dir, znorm)
    synth = LiveSynth(model, audio=audio_config, config=cfg)
    rate = synth.audio.sample_rate
    if input == "mic":
        chunks = mic_chunks(synth.hop, rate, max_seconds=max_seconds)
        next_chunk = next(chunks)  # fail on a missing microphone before touching the robot
        source: Chunks = _prepend(next_chunk, chunks)
    else:
        source = wav_chunks(input, synth.hop, rate)
    be = create(backend, url=url, out=out, audio=None if input == "mic" else input, config=cfg)
    try:
        result = run_live(synth, source, be, config=cfg)
    finally:
        be.close()
    p50, p99 = result.latency_ms()
    log.info(
        "live: %d frames, %d skipped, latency p50 %.2f ms, p99 %.2f ms",
        result.n_sent,
        result.skipped,
        p50,
        p99,
    )
    return result


def _prepend(first: tuple[np.ndarray, float], rest: Chunks) -> Chunks:
    yield first
    yield from rest
