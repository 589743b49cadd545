"""Speech activity at 100 Hz with Silero VAD (MIT), its ONNX model run on onnxruntime.

The model comes from the `silero-vad` wheel (installed with `--no-deps`: the ONNX model needs
neither torch nor torchaudio). It reads 16 kHz audio in chunks of CHUNK samples, each prefixed
with the previous chunk's last CONTEXT samples (zeros before the first), and carries a recurrent
state from chunk to chunk; each chunk gives one speech probability (32 ms). The probabilities are
held onto a 100 Hz clock on the video's time base, where time outside the audio track (no track,
a late or short track) is silence. Speech is the probability with hysteresis (`threshold` to
start, `release_threshold` to stop). `silences` applies issue 32's rule: silences over
`max_silence_s` cut, shorter ones are marked.
"""

from __future__ import annotations

import hashlib
import importlib.util
from dataclasses import dataclass
from fractions import Fraction
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.signal import resample_poly

from gesturebank.config import SpeechConfig
from gesturebank.errors import DetectionError

if TYPE_CHECKING:  # only for annotations: no audio decoder needed
    from gesturebank.audio.io import Audio

INSTALL = "pip install --no-deps silero-vad==6.2.3"
MODEL_RATE = 16000  # Hz; the model's other rate (8 kHz) is not used
CHUNK = 512  # samples per model call at 16 kHz (32 ms)
CONTEXT = 64  # samples of the previous chunk prefixed to each chunk
STATE_SHAPE = (2, 1, 128)
RATE_HZ = 100.0  # the speech-activity clock (the audio features' 10 ms hop)


@dataclass(frozen=True)
class SpeechActivity:
    """Speech activity on a uniform clock: frame k is the time t0 + k / rate_hz.

    probability: (N,) float32 speech probability in [0, 1] (0 where there is no audio).
    speech:      (N,) bool, the probability with hysteresis.
    """

    t0: float
    rate_hz: float
    probability: np.ndarray
    speech: np.ndarray

    @property
    def times(self) -> np.ndarray:
        return self.t0 + np.arange(len(self.speech)) / self.rate_hz


@dataclass(frozen=True)
class Silences:
    """Silences of a `SpeechActivity`, each a (start_s, end_s) pair on its clock.

    cut:    silences longer than max_silence_s (a clip is cut there).
    marked: the shorter ones (kept, marked as silence in `speech`).
    """

    cut: list[tuple[float, float]]
    marked: list[tuple[float, float]]


def model_path() -> Path:
    """The installed wheel's `silero_vad.onnx`; DetectionError with the install command if absent.

    Found with find_spec, without importing the package: its __init__ imports torch."""
    spec = importlib.util.find_spec("silero_vad")
    if spec is None or not spec.submodule_search_locations:
        raise DetectionError(f"speech activity needs the Silero VAD model: {INSTALL}")
    path = Path(next(iter(spec.submodule_search_locations))) / "data" / "silero_vad.onnx"
    if not path.is_file():
        raise DetectionError(
            f"{path}: Silero VAD model missing from the installed wheel: {INSTALL}"
        )
    return path


@cache
def _session() -> Any:
    """One onnxruntime session (one thread: the graph is tiny and runs chunk by chunk)."""
    import onnxruntime as ort

    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    return ort.InferenceSession(str(model_path()), options, providers=["CPUExecutionProvider"])


def model_inputs(signal: np.ndarray) -> np.ndarray:
    """`signal (n,)` at 16 kHz as the model's inputs: (ceil(n / CHUNK), CONTEXT + CHUNK) float32.

    Row i is chunk i (zero-padded at the end) prefixed with the last CONTEXT samples of chunk
    i − 1 (zeros for the first)."""
    x = np.asarray(signal, np.float32).ravel()
    n_chunks = -(-len(x) // CHUNK)
    padded = np.zeros(CONTEXT + n_chunks * CHUNK, np.float32)
    padded[CONTEXT : CONTEXT + len(x)] = x
    starts = np.arange(n_chunks) * CHUNK  # row i begins CONTEXT samples before chunk i
    return padded[starts[:, None] + np.arange(CONTEXT + CHUNK)]


def chunk_probabilities(signal: np.ndarray) -> np.ndarray:
    """Speech probability of each 512-sample chunk of `signal (n,)` at 16 kHz: (n_chunks,)."""
    session = _session()
    state = np.zeros(STATE_SHAPE, np.float32)
    sr = np.array(MODEL_RATE, np.int64)
    rows = model_inputs(signal)
    out = np.empty(len(rows), np.float32)
    for i, row in enumerate(rows):
        prob, state = session.run(None, {"input": row[None], "state": state, "sr": sr})
        out[i] = prob[0, 0]
    return out


def to_model_rate(signal: np.ndarray, sample_rate: int) -> np.ndarray:
    """`signal` resampled to 16 kHz by polyphase filtering (scipy's anti-aliasing FIR)."""
    x = np.asarray(signal, np.float32)
    if sample_rate == MODEL_RATE:
        return x
    ratio = Fraction(MODEL_RATE, int(sample_rate))
    return resample_poly(x, ratio.numerator, ratio.denominator).astype(np.float32)


def hysteresis(
    probability: np.ndarray, *, threshold: float, release_threshold: float
) -> np.ndarray:
    """(N,) bool: on from where `probability` reaches `threshold` until it falls below
    `release_threshold`."""
    on = False
    out = np.zeros(len(probability), bool)
    for i, p in enumerate(np.asarray(probability, np.float64)):
        on = p >= threshold if not on else p >= release_threshold
        out[i] = on
    return out


# The last track's chunk probabilities, by its samples' digest: a take asks for its audio's
# activity twice (who speaks, `extract.roles`; the clips' silences, `app.clip.take_activity`),
# and the model over the whole track is most of the cost (hashing is ~1 % of it).
_last: tuple[tuple[int, int, bytes], np.ndarray] | None = None


def _track_probabilities(signal: np.ndarray, sample_rate: int) -> np.ndarray:
    """`chunk_probabilities` of `signal` at `sample_rate`, computed once for the same samples
    asked for twice in a row."""
    global _last
    samples = np.ascontiguousarray(signal, np.float32)
    key = (int(sample_rate), len(samples), hashlib.blake2b(samples.data).digest())
    if _last is None or _last[0] != key:
        _last = (key, chunk_probabilities(to_model_rate(samples, sample_rate)))
    return _last[1]


def speech_activity(
    audio: Audio | None, *, t0: float, n_frames: int, config: SpeechConfig
) -> SpeechActivity:
    """Speech activity of `audio` for `n_frames` 100 Hz frames from `t0` (video clock, seconds).

    Frame k takes the probability of the chunk holding its centre t0 + (k + ½) / 100; frames
    outside the audio track (or all, when `audio` is None) have probability 0."""
    prob = np.zeros(n_frames, np.float32)
    if audio is not None and len(audio.signal):
        chunks = _track_probabilities(audio.signal, audio.sample_rate)
        centres = t0 + (np.arange(n_frames) + 0.5) / RATE_HZ
        idx = np.floor((centres - audio.start_s) * MODEL_RATE / CHUNK).astype(np.int64)
        n_samples_16k = len(audio.signal) * MODEL_RATE / audio.sample_rate
        inside = (idx >= 0) & ((centres - audio.start_s) * MODEL_RATE < n_samples_16k)
        prob[inside] = chunks[np.minimum(idx[inside], len(chunks) - 1)]
    speech = hysteresis(
        prob, threshold=config.threshold, release_threshold=config.release_threshold
    )
    return SpeechActivity(t0, RATE_HZ, prob, speech)


def silences(activity: SpeechActivity, *, max_silence_s: float) -> Silences:
    """The runs of no speech in `activity`, split by issue 32's rule: longer than `max_silence_s`
    → cut, otherwise marked. Leading and trailing silences count like any other."""
    speech = np.asarray(activity.speech, bool)
    edges = np.flatnonzero(np.diff(np.r_[False, ~speech, False].astype(np.int8)))
    cut: list[tuple[float, float]] = []
    marked: list[tuple[float, float]] = []
    for start, end in zip(edges[::2], edges[1::2], strict=True):
        span = (activity.t0 + start / activity.rate_hz, activity.t0 + end / activity.rate_hz)
        (cut if (end - start) / activity.rate_hz > max_silence_s else marked).append(span)
    return Silences(cut, marked)
