"""Live mode (§4.4.2): speech in, robot motion out, one pose every 10 ms.

Per 10 ms chunk of audio (160 samples at 16 kHz): the latest 25 ms window (400 samples) →
one LogFB-26 frame → z-norm with the model's stored stats → the model's step → ν⁻¹ (Eq. 3.14
inverted) → per-joint constant-acceleration Kalman filter (q = 0.5, r = 0.01) → safety (limits,
speed) → backend. Input: the microphone (sounddevice) or a WAV streamed in real time, so the whole
loop is testable without an audio device. Per-frame latency (chunk available → pose handed to the
backend) is measured and summarised as p50/p99.

A listener model (`train --target listener`, seed 004) makes the robot listen: its input is the
feature frame plus the speaker's speaking flag (1.0 while the person at the microphone speaks:
`audio.vad_stream`, causal), and it drives only the head (`pepper.HEAD_JOINTS`); every other
joint holds the start pose through the same Kalman filter and safety limits.

The model is any `FrameModel` with what it needs around it (`LiveModel`): the audio config it
was trained with, z-norm stats (the dissertation's online mode used the whole dataset's) and the
robot profile. The caller builds it: `gesturebank live` from the model folder `gesturebank train`
writes (`gesturebank.app.robot.load_frame_model`, which runs its ONNX graph one frame at a time
with `gesturebank.train.model_folder.OnnxFrameModel`).
"""

from __future__ import annotations

import logging
import os
import queue
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from gesturebank.audio.features import apply_znorm, frame_features, frame_length, frame_step
from gesturebank.audio.vad_stream import StreamingSpeech
from gesturebank.config import AudioConfig, PlaybackConfig, SpeechConfig
from gesturebank.errors import InputError, RobotError
from gesturebank.filters import KalmanConstAcc
from gesturebank.robot import pepper
from gesturebank.robot.audio_out import PORTAUDIO_HINT
from gesturebank.robot.backends import Backend, Command
from gesturebank.robot.clock import Clock, RealClock, VirtualClock
from gesturebank.robot.playback import Player
from gesturebank.robot.safety import SafetyFilter, safe_pose, speed_profile

log = logging.getLogger(__name__)

HEAD = np.isin(np.array(pepper.JOINTS), pepper.HEAD_JOINTS)  # (11,) the joints a listener moves

PathLike = str | os.PathLike[str]


# --------------------------------------------------------------------------------------------------
# The model side


class FrameModel(Protocol):
    """One frame in, one pose out; stateful models keep their state between calls."""

    def step(self, features01: np.ndarray) -> np.ndarray:
        """z-normalised features `(F,)` → angles in [0, 1] `(11,)`."""
        ...

    def reset(self) -> None:
        """Forget the state (a new utterance)."""
        ...


@dataclass(frozen=True, eq=False)
class LiveModel:
    """A frame model with what it needs around it: z-norm stats `(F,)`, robot, audio config, the
    reach mode of the angles it was trained on (None: its folder does not say), and whether it
    is a listener model (`train --target listener`: it also takes the speaking flag and drives
    the head only)."""

    model: FrameModel
    audio_mean: np.ndarray
    audio_std: np.ndarray
    robot: pepper.RobotProfile
    audio: AudioConfig
    reach: str | None = None
    listener: bool = False

    @property
    def target(self) -> str:
        """What the model predicts, as model.json says: "speaker" or "listener"."""
        return "listener" if self.listener else "speaker"

    @property
    def profile(self) -> str:
        """The robot profile's name."""
        return self.robot.name

    @property
    def features(self) -> str:
        return self.audio.features


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


# --------------------------------------------------------------------------------------------------
# The per-frame pipeline (no I/O)


class LiveSynth:
    """Chunk of audio in, safe pose out; holds the audio window, the model, Kalman and safety."""

    def __init__(
        self,
        model: LiveModel,
        *,
        audio: AudioConfig | None = None,
        config: PlaybackConfig | None = None,
        start_pose: np.ndarray | None = None,
        speech: SpeechConfig | None = None,
    ) -> None:
        """speech: the speech detection of a listener model (default: SpeechConfig())."""
        self.audio = audio or model.audio
        if self.audio.features != model.features:
            raise InputError(
                f"model expects {model.features} features, audio config gives {self.audio.features}"
            )
        cfg = config or PlaybackConfig()
        self.model = model
        self.hop = frame_step(self.audio)  # 160 samples = 10 ms
        self.dt = self.hop / self.audio.sample_rate
        self.profile = speed_profile(model.robot, cfg.max_speed_fraction)
        start = safe_pose(pepper.neutral_pose() if start_pose is None else start_pose, self.profile)
        # +1 sample: pre-emphasis needs the sample just before the window (Eq. 3.1).
        self.window = np.zeros(frame_length(self.audio) + 1, np.float64)
        self.kalman = KalmanConstAcc(
            len(pepper.JOINTS), dt=self.dt, q=cfg.kalman_q, r=cfg.kalman_r, x0=start
        )
        self.safety = SafetyFilter(self.profile, start)
        self.rest = start  # a listener holds every joint but the head here
        self.listening = model.listener
        self.speech = (
            StreamingSpeech(sample_rate=self.audio.sample_rate, config=speech or SpeechConfig())
            if self.listening
            else None
        )
        model.model.reset()

    def push(self, chunk: np.ndarray) -> np.ndarray:
        """One hop of audio `(hop,)` float in [-1, 1] → the pose to send `(11,)` float32 rad."""
        x = np.asarray(chunk, np.float64).reshape(-1)
        if len(x) != self.hop:
            raise InputError(f"live audio chunks must have {self.hop} samples, got {len(x)}")
        w = self.window
        w[: -self.hop] = w[self.hop :]
        w[-self.hop :] = x
        feats = frame_features(
            w[1:], self.audio.sample_rate, config=self.audio, previous=float(w[0])
        )
        z = apply_znorm(feats, self.model.audio_mean, std=self.model.audio_std)
        if self.speech is not None:  # the speaker's flag: the person at the microphone speaks
            z = np.append(z, np.float32(self.speech.push(x)))
        angles01 = self.model.model.step(z)
        angles = pepper.denormalise(angles01.reshape(1, -1), self.profile)[0]  # ν⁻¹, Eq. 3.14
        if self.listening:
            angles = np.where(HEAD, angles, self.rest)
        smooth = self.kalman.step(angles)
        return self.safety.step(smooth, self.dt)


# --------------------------------------------------------------------------------------------------
# Audio sources: yield (chunk (hop,), time.monotonic() at which the chunk became available)

Chunks = Iterator[tuple[np.ndarray, float]]


def wav_chunks(path: PathLike, hop: int, *, sample_rate: int, realtime: bool = True) -> Chunks:
    """Stream an audio file in `hop`-sample chunks; in real time, chunk k becomes available
    (k + 1) hops after the start, as from a microphone. A partial last chunk is dropped."""
    from gesturebank.audio.io import read_audio

    track = read_audio(path, sample_rate=sample_rate)
    if track is None or len(track.signal) < hop:
        raise InputError(f"{os.fspath(path)}: no audio to stream")
    signal = track.signal
    t_start = time.monotonic()
    for k in range(len(signal) // hop):
        due = t_start + (k + 1) * hop / sample_rate
        if realtime:
            wait = due - time.monotonic()
            if wait > 0:
                time.sleep(wait)
        else:
            due = time.monotonic()
        yield signal[k * hop : (k + 1) * hop], due


def mic_chunks(hop: int, sample_rate: int, *, max_seconds: float | None = None) -> Chunks:
    """Stream the default microphone; InputError (one line) when there is none."""
    try:
        import sounddevice
    except OSError as exc:  # the PortAudio library itself is missing
        raise InputError(
            f"microphone: no audio input available ({_first_line(exc)}); {PORTAUDIO_HINT}"
        ) from None
    chunks: queue.Queue[tuple[np.ndarray, float]] = queue.Queue()

    def callback(indata: np.ndarray, frames: int, time_info: Any, status: Any) -> None:
        chunks.put((indata[:, 0].astype(np.float64), time.monotonic()))

    try:
        stream = sounddevice.InputStream(
            samplerate=sample_rate, blocksize=hop, channels=1, dtype="float32", callback=callback
        )
    except Exception as exc:  # sounddevice.PortAudioError: no device / unsupported rate
        raise InputError(f"microphone: cannot open an input device ({_first_line(exc)})") from None
    n_max = None if max_seconds is None else int(max_seconds * sample_rate / hop)
    with stream:
        k = 0
        while n_max is None or k < n_max:
            try:
                yield chunks.get(timeout=1.0)
            except queue.Empty:
                raise InputError("microphone: no audio arrived for 1 s") from None
            k += 1


# --------------------------------------------------------------------------------------------------
# The loop


@dataclass
class LiveResult:
    """latencies_s `(K,)`: chunk available → pose handed to the backend, per frame, seconds."""

    status: str
    n_chunks: int
    n_sent: int
    latencies_s: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def skipped(self) -> int:
        return self.n_chunks - self.n_sent

    def latency_ms(self) -> tuple[float, float]:
        """p50, p99 of the per-frame latency, milliseconds."""
        if not len(self.latencies_s):
            return (float("nan"), float("nan"))
        ms = self.latencies_s * 1000
        return float(np.percentile(ms, 50)), float(np.percentile(ms, 99))


def run_live(
    synth: LiveSynth,
    chunks: Chunks,
    *,
    backend: Backend,
    config: PlaybackConfig | None = None,
    clock: Clock | None = None,
) -> LiveResult:
    """Move smoothly to neutral, then one pose per chunk until the input ends (or Ctrl-C), then
    back to neutral. RobotError (one line) if the robot is lost."""
    cfg = config or PlaybackConfig()
    clk = clock or (RealClock() if backend.realtime else VirtualClock())
    run = Player(backend, clock=clk, config=cfg, profile=synth.profile)
    neutral = safe_pose(pepper.neutral_pose(), synth.profile)
    run.t0 = clk.now()
    run.move(neutral, "start", cfg.start_s, 0.0)
    latencies: list[float] = []
    n_chunks, status, t_live = 0, "completed", 0.0
    try:
        t_first: float | None = None
        for chunk, available in chunks:
            n_chunks += 1
            t_first = available - synth.dt if t_first is None else t_first
            t_live = available - t_first
            pose = synth.push(chunk)
            fraction = cfg.max_speed_fraction
            backend.send(Command(t=t_live, angles=pose, phase="live", fraction=fraction))
            run.last = pose
            latencies.append(time.monotonic() - available)
            log.debug("live frame %d: latency %.3f ms", n_chunks, latencies[-1] * 1000)
    except KeyboardInterrupt:
        status = "interrupted"
    except RobotError:
        if not backend.connected:
            raise
        _back(run, t_live)
        raise
    run.t0 = clk.now() - t_live  # the return move continues the live clock
    run.back_to_neutral()
    return LiveResult(status, n_chunks, len(latencies), np.asarray(latencies))


def _back(run: Player, t_live: float) -> None:
    try:
        run.t0 = run.clock.now() - t_live
        run.back_to_neutral()
    except Exception as exc:
        log.warning("could not return to the neutral pose: %s", exc)
