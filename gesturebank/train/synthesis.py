"""Offline synthesis (§4.4.1): a trained model folder and a speech file → an angle timeline file."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np

from gesturebank.audio.features import apply_znorm, features
from gesturebank.config import SpeechConfig
from gesturebank.datasets.listener import HEAD, listener_inputs
from gesturebank.errors import InputError
from gesturebank.robot import pepper
from gesturebank.train import model_folder
from gesturebank.train.eval.evaluate import postprocess
from gesturebank.train.export import OnnxModel
from gesturebank.train.model_folder import MODEL_ONNX

if TYPE_CHECKING:  # the decoder is imported when a file is read
    from gesturebank.audio.io import Audio

PathLike = str | os.PathLike[str]


def synthesize(
    model_dir: PathLike,
    *,
    audio_path: PathLike,
    out_csv: PathLike,
    znorm: str = "*",
    speech: SpeechConfig | None = None,
) -> np.ndarray:
    """Offline synthesis (§4.4.1): audio file → angles `(N, 11)` rad, also written as CSV.

    Features with the training audio config → z-norm (`znorm`: "*" = whole-dataset stats, as the
    dissertation's synthesis; a subject name = that subject's; "self" = the file's own) → ONNX
    model → ν⁻¹ → Butterworth post-smoothing → clamp. Written as an angle timeline
    (`robot.timeline`): time_s (centre of each feature window, seconds from the first sample)
    and the 11 joint names, under a header naming the model's robot profile and reach mode.

    A listener model (`train --target listener`) also takes whether the file's speaker speaks
    (Silero VAD with `speech`'s thresholds, default SpeechConfig()) and moves only the head: the
    other joints hold the neutral pose.
    """
    from gesturebank.audio.io import read_audio
    from gesturebank.robot.timeline import Timeline, write_timeline

    folder = model_folder.load(model_dir)
    info, cfg, audio_cfg = folder.info, folder.train_config, folder.audio
    track = read_audio(audio_path, sample_rate=audio_cfg.sample_rate)
    if track is None:
        raise InputError(f"{audio_path}: no audio track")
    feats = features(track.signal, track.sample_rate, config=audio_cfg)
    if znorm == "self":
        mean, std = feats.mean(axis=0), feats.std(axis=0)
    else:
        mean, std = folder.znorm(znorm)
    times = np.arange(len(feats)) * audio_cfg.winstep_s + audio_cfg.winlen_s / 2
    x = apply_znorm(feats, mean, std=std)
    if info.target == "listener":
        x = listener_inputs(audio=x, partner_speaking=_speaking(track, times, speech))
    # a model with a latent (the CVAE) samples z, drawn with the training seed: reproducible
    pred01 = OnnxModel(folder.file(MODEL_ONNX)).predict(x, z_seed=cfg.seed)
    angles = postprocess(
        pred01, folder.profile, rate_hz=float(info.need(folder.path, "rate_hz")), config=cfg
    )
    if info.target == "listener":
        rest = pepper.clamp(pepper.neutral_pose().reshape(1, -1), folder.profile)
        angles = np.where(HEAD, angles, rest).astype(angles.dtype)
    line = Timeline.of(  # reach None: older model folders do not say
        times, angles, profile=folder.profile.name, reach=info.reach
    )
    write_timeline(out_csv, line)
    return angles


def _speaking(track: Audio, times: np.ndarray, speech: SpeechConfig | None) -> np.ndarray:
    """(N,) bool: speech heard at each of `times` (s from the file's first sample)."""
    from gesturebank.audio.vad import RATE_HZ, speech_activity

    t0 = float(times[0]) - 0.5 / RATE_HZ  # activity frame k is centred on t0 + (k + ½) / rate
    activity = speech_activity(track, t0=t0, n_frames=len(times), config=speech or SpeechConfig())
    return activity.speech
