"""`gesturebank replay` and `live`: their options, and their work as plain functions
(`replay_command`, `live_command`; `app.robot.load_frame_model` readies a model folder for live
mode)."""

from __future__ import annotations

import logging
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import numpy as np
import typer

from gesturebank.app.robot import load_frame_model, side_by_side
from gesturebank.cli.options import (
    BackendOption,
    ConfigOption,
    ForceOption,
    ModelDirArg,
    OutFileOption,
    SetOption,
    pick,
    resolve_config,
)
from gesturebank.cli.terminal import out, user_errors
from gesturebank.config import (
    AudioConfig,
    PlaybackConfig,
    RenderConfig,
    RobotConfig,
    SpeechConfig,
    Target,
)
from gesturebank.errors import InputError, RobotError
from gesturebank.fileio import keep_existing
from gesturebank.robot import pepper
from gesturebank.robot.backends import create

if TYPE_CHECKING:
    from gesturebank.robot.online import Chunks, LiveResult
    from gesturebank.robot.playback import PlaybackResult

log = logging.getLogger(__name__)

PathLike = str | os.PathLike[str]


def replay_command(
    angles_csv: PathLike,
    *,
    backend: str,
    url: str | None = None,
    out: PathLike | None = None,
    audio: PathLike | None = None,
    config: PlaybackConfig | None = None,
    clip: str | None = None,
    compare: PathLike | Sequence[PathLike] | None = None,
    profile: str | None = None,
    clamp: bool = False,
    render: RenderConfig | None = None,
) -> PlaybackResult | Path:
    """`gesturebank replay ANGLES.csv --backend naoqi|sim|record [--url|--out] [--audio]`.

    `clip`: read the timeline from that clip of the dataset folder `angles_csv` instead.
    `compare` (sim only): more timeline CSVs rendered side by side; returns the video path.
    `render` (sim only): the look of the video.
    `clamp`: play timelines far outside the limits clamped instead of refusing them.
    An interrupted sim replay writes no video.
    """
    # imported here, as every command's work is: the CLI starts without them
    from gesturebank.datasets.listing import clip_timeline
    from gesturebank.robot.audio_out import DeviceAudio, Speaking
    from gesturebank.robot.playback import play
    from gesturebank.robot.safety import check_timeline
    from gesturebank.robot.timeline import read_timeline

    cfg = config or PlaybackConfig()
    robot = pepper.load_profile(profile or RobotConfig().profile)
    timeline = clip_timeline(angles_csv, clip) if clip else read_timeline(angles_csv)
    name = f"{os.fspath(angles_csv)} clip {clip}" if clip else os.fspath(angles_csv)
    if timeline.profile and timeline.profile != robot.name:  # the file's header says so
        log.warning(
            "%s: angles made for %s, played within the %s limits (robot.profile)",
            name,
            timeline.profile,
            robot.name,
        )
    check_timeline(timeline, name=name, profile=robot, config=cfg, clamp=clamp)
    others = (
        [] if compare is None else [compare] if isinstance(compare, str | os.PathLike) else compare
    )
    if others:
        if backend != "sim" or out is None:
            raise RobotError("--compare needs --backend sim and --out VIDEO.mp4")
        timelines = [timeline]
        for path in others:
            other = read_timeline(path)
            check_timeline(other, name=os.fspath(path), profile=robot, config=cfg, clamp=clamp)
            timelines.append(other)
        label = f"{Path(angles_csv).name} {clip}" if clip else Path(angles_csv).stem
        return side_by_side(
            timelines,
            labels=[label, *(Path(p).stem for p in others)],
            out=out,
            profile=robot,
            audio=audio,
            config=cfg,
            render=render,
        )
    extra = (
        {"render": render} if backend == "sim"
        else {"profile": robot.name, "reach": timeline.reach}  # the limits it was played in
        if backend == "record"
        else {}
    )  # fmt: skip
    be = create(backend, url=url, out=out, audio=audio, config=cfg, **extra)
    try:
        if isinstance(be, Speaking):  # the robot plays it (naoqi), not this computer
            sound = be.speaker
        else:
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


def live_command(
    model_dir: PathLike,
    *,
    backend: str,
    input: str = "mic",
    url: str | None = None,
    out: PathLike | None = None,
    config: PlaybackConfig | None = None,
    audio_config: AudioConfig | None = None,
    render: RenderConfig | None = None,
    max_seconds: float | None = None,
    znorm: str = "*",
    csv: bool = False,
    role: str | None = None,
    speech: SpeechConfig | None = None,
) -> LiveResult:
    """`gesturebank live MODEL_DIR --backend naoqi|sim|record [--input mic|FILE.wav]
    [--role speaker|listener]`.

    `role`: what the robot does — "speaker" (moves with its own speech) or "listener" (listens
    and nods: the head only, from a listener model); None: the model's target. A model trained
    for the other role is refused in one line. `speech`: the listener's speech detection.

    `csv` (record only; also when `out` ends in .csv): write the poses sent as an angle
    timeline that `replay` and `export` read, instead of the JSON lines of every call."""
    # imported here: the audio-feature stack costs seconds that `replay` need not wait
    from gesturebank.robot.online import (
        LiveSynth,
        mic_chunks,
        run_live,
        wav_chunks,
    )

    cfg = config or PlaybackConfig()
    if csv and backend != "record":
        raise InputError(f"--csv writes the record backend's file; not with --backend {backend}")
    model = load_frame_model(model_dir, znorm)
    if role is not None and role != model.target:
        how = "--target listener" if role == "listener" else "--target speaker (the default)"
        raise InputError(
            f"{model_dir}: a {model.target} model cannot play --role {role}: train one with "
            f"`gesturebank train {how}` (a causal model: lstm, aud2motion or mlp)"
        )
    synth = LiveSynth(model, audio=audio_config, config=cfg, speech=speech)
    rate = synth.audio.sample_rate
    if input == "mic":
        chunks = mic_chunks(synth.hop, rate, max_seconds=max_seconds)
        next_chunk = next(chunks)  # fail on a missing microphone before touching the robot
        source: Chunks = _prepend(next_chunk, chunks)
    else:
        source = wav_chunks(input, synth.hop, sample_rate=rate)
    extra: dict[str, object] = (
        {"render": render} if backend == "sim"
        else {"csv": csv, "profile": synth.profile.name, "reach": model.reach}
        if backend == "record"
        else {}
    )  # fmt: skip
    be = create(backend, url=url, out=out, audio=None if input == "mic" else input, config=cfg,
                **extra)  # fmt: skip
    try:
        result = run_live(synth, source, backend=be, config=cfg)
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


def replay(
    angles: Annotated[
        Path,
        typer.Argument(
            help="Angle timeline (.csv from synthesize, export or record; a record .jsonl), "
            "or a dataset folder with --clip."
        ),
    ],
    *,
    backend: BackendOption,
    url: Annotated[
        str | None, typer.Option(help="naoqi: the robot's address, e.g. tcp://192.168.1.10:9559.")
    ] = None,
    out_file: OutFileOption = None,
    audio: Annotated[
        Path | None,
        typer.Option(
            help="Speech to play (naoqi: on the robot, the motion timed from its sound; "
            "sim: muxed into the video)."
        ),
    ] = None,
    clip: Annotated[
        str | None,
        typer.Option(
            help="Play this clip of the dataset folder ANGLES instead (a clip id, or a take id "
            "when the take has one clip; `gesturebank clips` lists them), with its source "
            "audio unless --audio or --no-audio."
        ),
    ] = None,
    no_audio: Annotated[
        bool, typer.Option("--no-audio", help="--clip: play without the clip's source audio.")
    ] = False,
    compare: Annotated[
        list[Path] | None,
        typer.Option(help="sim: another CSV rendered side by side, with its name (repeatable)."),
    ] = None,
    clamp: Annotated[
        bool, typer.Option("--clamp", help="Play angles far outside the limits clamped.")
    ] = False,
    config_file: ConfigOption = None,
    sets: SetOption = None,
    force: ForceOption = False,
) -> None:
    """Play an angle timeline on Pepper, a simulator render, or a file — safely.

    Every backend gets angles inside the robot's limits and within a share of its joint speeds
    (playback.max_speed_fraction); the robot moves smoothly from its current pose to the first
    frame and back to neutral at the end, on Ctrl-C or on an error. A lost connection stops
    playback with a one-line error. A timeline that looks wrong is refused: angles far outside
    the limits (degrees?) unless --clamp, a gap in its times, a first frame long after 0 s.
    """

    from gesturebank.cli.robot import replay_command

    with user_errors(), tempfile.TemporaryDirectory(prefix="gesturebank-replay-") as scratch:
        keep_existing([out_file] if out_file else [], force=force)
        config = resolve_config(config_file=config_file, sets=sets, flags={})
        if clip is not None:
            from gesturebank.datasets.listing import clip_to_play

            chosen = clip_to_play(
                angles,
                clip,
                scratch=Path(scratch),
                with_audio=audio is None and not no_audio and backend != "record",
            )
            for warning in chosen.warnings:
                typer.echo(f"warning: {warning}", err=True)
            clip, audio = chosen.clip_id, audio or chosen.audio
        try:
            result = replay_command(
                angles_csv=angles,
                backend=backend,
                url=url,
                out=out_file,
                audio=audio,
                config=config.playback,
                clip=clip,
                compare=compare,
                profile=config.robot.profile,
                clamp=clamp,
                render=config.render,
            )
        except KeyboardInterrupt:  # while the sim renders: the video is never half-written
            result = None
    status = "interrupted" if result is None else getattr(result, "status", "done")
    where = f" → {out_file}" if out_file else ""
    if status == "interrupted" and backend == "sim":
        where = f", nothing written to {out_file}"
    out.print(f"replay {status} on {backend}{where}", highlight=False, soft_wrap=True)
    if status == "interrupted":
        raise typer.Exit(130)


def live(
    model_dir: ModelDirArg,
    *,
    backend: BackendOption,
    input_: Annotated[
        str, typer.Option("--input", help="'mic' (the default microphone) or a WAV file.")
    ] = "mic",
    url: Annotated[str | None, typer.Option(help="naoqi: the robot's address.")] = None,
    out_file: OutFileOption = None,
    znorm: Annotated[
        str, typer.Option(help="Audio z-norm stats: '*' (whole training set) or a subject.")
    ] = "*",
    seconds: Annotated[float | None, typer.Option(help="Stop after this many seconds.")] = None,
    as_csv: Annotated[
        bool,
        typer.Option(
            "--csv",
            help="record: write the poses sent as an angle-timeline CSV (replay/export read it) "
            "instead of the JSON lines of every call.",
        ),
    ] = False,
    role: Annotated[
        Target | None,
        typer.Option(
            parser=pick(Target),
            help="'speaker': the robot moves as it speaks; 'listener': it listens and nods, only "
            "its head moving with the person's speech (a causal model trained with --target "
            "listener). Default: the model's target.",
            show_default=False,
        ),
    ] = None,
    config_file: ConfigOption = None,
    sets: SetOption = None,
    force: ForceOption = False,
) -> None:
    """Live synthesis: speech from a microphone (or a WAV in real time) drives the robot.

    Every 10 ms: the latest 25 ms of audio → one feature frame → the model (a stateful step for
    the LSTM and aud2motion) → inverse normalisation → Kalman smoothing → safety → the backend.
    Per-frame latency p50/p99 is reported at the end. Causal models only (mlp, lstm,
    aud2motion); the others need future audio: play them with synthesize.

    --role listener (seed 004): the robot listens; a listener model (train --target listener)
    turns the speech and whether the person speaks (Silero VAD, [speech] thresholds) into head
    motion; the arms and hip hold still; the same safety and speed limits apply.
    """
    from gesturebank.cli.robot import live_command

    with user_errors():
        keep_existing([out_file] if out_file else [], force=force)
        config = resolve_config(config_file=config_file, sets=sets, flags={})
        result = live_command(
            model_dir=model_dir,
            backend=backend,
            input=input_,
            url=url,
            out=out_file,
            config=config.playback,
            render=config.render,
            max_seconds=seconds,
            znorm=znorm,
            csv=as_csv,
            role=role,
            speech=config.speech,
        )
    p50, p99 = result.latency_ms()
    out.print(
        f"live {result.status}: {result.n_sent} of {result.n_chunks} frames sent, "
        f"{result.skipped} skipped; latency p50 {p50:.2f} ms, p99 {p99:.2f} ms",
        highlight=False,
        soft_wrap=True,
    )
    if result.status == "interrupted":
        raise typer.Exit(130)
