"""Offline synthesis (§4.4.1): a trained model folder and a speech file → an angle timeline file."""

from __future__ import annotations

import os

import numpy as np

from gesturebank.errors import InputError
from gesturebank.extract.audio_features import apply_znorm, features
from gesturebank.train import model_folder
from gesturebank.train.eval.evaluate import postprocess
from gesturebank.train.export import OnnxModel
from gesturebank.train.model_folder import MODEL_ONNX

PathLike = str | os.PathLike[str]


def synthesize(
    model_dir: PathLike,
    audio_path: PathLike,
    out_csv: PathLike,
    *,
    znorm: str = "*",
) -> np.ndarray:
    """Offline synthesis (§4.4.1): audio file → angles `(N, 11)` rad, also written as CSV.

    Features with the training audio config → z-norm (`znorm`: "*" = whole-dataset stats, as the
    dissertation's synthesis; a subject name = that subject's; "self" = the file's own) → ONNX
    model → ν⁻¹ → Butterworth post-smoothing → clamp. Written as an angle timeline
    (`robot.timeline`): time_s (centre of each feature window, seconds from the first sample)
    and the 11 joint names, under a header naming the model's robot profile and reach mode.
    """
    from gesturebank.extract.audio_io import read_audio
    from gesturebank.robot.timeline import Timeline, write_timeline

    folder = model_folder.load(model_dir)
    info, cfg, audio_cfg = folder.info, folder.train_config, folder.audio
    track = read_audio(audio_path, sample_rate=audio_cfg.sample_rate)
    if track is None:
        raise InputError(f"{audio_path}: no audio track")
    feats = features(track.signal, track.sample_rate, audio_cfg)
    if znorm == "self":
        mean, std = feats.mean(axis=0), feats.std(axis=0)
    else:
        mean, std = folder.znorm(znorm)
    # a model with a latent (the CVAE) samples z, drawn with the training seed: reproducible
    pred01 = OnnxModel(folder.file(MODEL_ONNX)).predict(
        apply_znorm(feats, mean, std), z_seed=cfg.seed
    )
    angles = postprocess(pred01, folder.profile, float(info.need(folder.path, "rate_hz")), cfg)
    times = np.arange(len(angles)) * audio_cfg.winstep_s + audio_cfg.winlen_s / 2
    line = Timeline.of(  # reach None: older model folders do not say
        times, angles, profile=folder.profile.name, reach=info.reach
    )
    write_timeline(out_csv, line)
    return angles
