"""Speech activity as audio arrives (live mode's listener): the same Silero VAD as
`audio.vad`, its recurrent state carried from chunk to chunk, one probability per 512 new
samples at 16 kHz (32 ms), with the same hysteresis (`speech.threshold` to start,
`speech.release_threshold` to stop). Causal: the flag after a push depends on audio up to it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from gesturebank.audio.vad import CHUNK, CONTEXT, MODEL_RATE, STATE_SHAPE, _session
from gesturebank.config import SpeechConfig
from gesturebank.errors import InputError


class StreamingSpeech:
    """Push 16 kHz audio in any chunk sizes; `speaking` says whether speech is heard now."""

    def __init__(self, *, sample_rate: int, config: SpeechConfig) -> None:
        if sample_rate != MODEL_RATE:
            raise InputError(
                f"live speech detection needs {MODEL_RATE} Hz audio, the audio config gives "
                f"{sample_rate} Hz"
            )
        self.config = config
        self.session: Any = _session()
        self.state = np.zeros(STATE_SHAPE, np.float32)
        self.rate = np.array(MODEL_RATE, np.int64)
        self.pending = np.zeros(CONTEXT, np.float32)  # the last CONTEXT samples, then new ones
        self.speaking = False
        self.probability = 0.0

    def push(self, chunk: np.ndarray) -> bool:
        """Add `chunk (n,)` float in [-1, 1]; run the model on every whole 512 samples it
        completes; return whether speech is heard (the hysteresis state)."""
        self.pending = np.concatenate([self.pending, np.asarray(chunk, np.float32).ravel()])
        while len(self.pending) >= CONTEXT + CHUNK:
            row = self.pending[: CONTEXT + CHUNK]
            prob, self.state = self.session.run(
                None, {"input": row[None], "state": self.state, "sr": self.rate}
            )
            self.probability = float(prob[0, 0])
            self.pending = self.pending[CHUNK:]
            c = self.config
            limit = c.release_threshold if self.speaking else c.threshold
            self.speaking = self.probability >= limit
        return self.speaking
