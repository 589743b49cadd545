"""Options of the sound: the speech features on the frame clock (`[audio]`) and speech activity
and who speaks (`[speech]`).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from gesturebank.config.section import Section

FeatureKind = Literal["logfb26", "logfb52", "logfb78", "mfcc13"]


class AudioConfig(Section):
    sample_rate: int = Field(16000, ge=8000, description="Audio is resampled to this rate, Hz.")
    features: FeatureKind = Field(
        "logfb26",
        description="LogFB-26 (default), with deltas (52) and delta-deltas (78), or MFCC-13.",
    )
    preemph: float = Field(0.97, ge=0, lt=1, description="Pre-emphasis coefficient.")
    winlen_s: float = Field(0.025, gt=0, description="Analysis window length, seconds.")
    winstep_s: float = Field(0.01, gt=0, description="Hop between frames, seconds (= 100 Hz).")
    window: Literal["none", "hamming"] = Field(
        "none",
        description="Window function on each frame: 'none' (rectangular) is the default of "
        "python_speech_features' logfbank and mfcc, the dissertation's features; 'hamming' is "
        "Eq. 3.2.",
    )
    nfft: int = Field(512, ge=64, description="FFT size; must cover winlen_s × sample_rate.")
    nfilt: int = Field(26, ge=1, le=128, description="Number of Mel filters.")
    delta_n: int = Field(2, ge=1, description="Half-width of the delta regression window.")

    @model_validator(mode="after")
    def _nfft(self) -> AudioConfig:
        if self.nfft < round(self.winlen_s * self.sample_rate):
            raise ValueError("nfft must be at least winlen_s × sample_rate samples")
        return self


class SpeechConfig(Section):
    """Speech activity (Silero VAD) and who speaks (mouth opening against the speech envelope)."""

    threshold: float = Field(
        0.5,
        gt=0,
        lt=1,
        description="Speech starts where the VAD's speech probability reaches this.",
    )
    release_threshold: float = Field(
        0.35,
        gt=0,
        lt=1,
        description="Speech ends only where the probability falls below this (hysteresis: no "
        "flicker on a probability hovering near `threshold`).",
    )
    max_silence_s: float = Field(
        2.0,
        gt=0,
        description="Silences longer than this cut a clip; shorter ones are marked in `speech`.",
    )
    min_face_px: float = Field(
        48.0,
        gt=0,
        description="Faces narrower than this (pixels, estimated from the eyes) get no mouth "
        "measurement.",
    )
    max_face_turn: float = Field(
        1.0,
        gt=0,
        description="A face counts as facing the camera when its nose lies within this many half "
        "eye distances of the eyes' midpoint, along the eye line (about tan(yaw): 1 = 45°).",
    )
    min_face_confidence: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Face keypoints (nose, eyes) below this confidence count as unseen.",
    )
    speaking_window_s: float = Field(
        1.5,
        gt=0,
        description="Sliding window over which mouth-opening speed is correlated with the speech "
        "envelope, seconds.",
    )
    still_mouth_range: float = Field(
        0.03,
        ge=0,
        description="A mouth whose opening (share of the face's height) spans less than this "
        "within a window (10th to 90th percentile) is still there: speaking score 0. Closed "
        "mouths measured 0.0015-0.015 (Pose2Sim Demo_MultiPerson cam04).",
    )
    speaking_max_lag_s: float = Field(
        0.25,
        ge=0,
        description="Largest delay of the mouth behind the speech envelope searched, seconds.",
    )
    mouths: bool = Field(
        True,
        description="Measure every tracked person's mouth to find who speaks when (per-person "
        "role tracks; the main speaker is the one who speaks). Off: the main speaker is chosen "
        "by size, centrality, confidence, persistence and speech following alone.",
    )
    # Issue 43: who speaks is in doubt only where somebody else is in the picture; a lone
    # person's mouth decides nothing, and on the talking demo it was most of the face model's
    # passes.
    mouths_alone: bool = Field(
        False,
        description="Also read the mouth of a person alone in the picture, for their role "
        "(speaking/listening; off: unknown there). With several people in the picture the "
        "mouths are read to find who speaks either way.",
    )
    mouth_rate_hz: float = Field(
        15.0,
        gt=0,
        description="Mouths are measured on at most this many frames a second (the face "
        "landmark model's cost).",
    )
    speaking_threshold: float = Field(
        0.5,
        gt=-1,
        lt=1,
        description="A person speaks where their speaking score reaches this while speech is "
        "heard.",
    )
    min_speaking_s: float = Field(
        1.0,
        ge=0,
        description="A person must speak this long in a shot to lead its main-speaker choice; a "
        "turn shorter than this does not change the main speaker.",
    )

    @model_validator(mode="after")
    def _hysteresis(self) -> SpeechConfig:
        if self.release_threshold > self.threshold:
            raise ValueError("release_threshold must not exceed threshold")
        return self
