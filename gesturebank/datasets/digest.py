"""What a dataset's takes were built and measured with: the digests of the config sections
that change a take's content or its stored metrics (a take built otherwise is rebuilt)."""

from __future__ import annotations

import hashlib
import json

from gesturebank.config import Config, QCConfig
from gesturebank.qc.metrics import measure_settings


def measure_digest(*, qc: QCConfig, profile: str) -> str:
    """What the stored metrics were measured with: qc.metrics.measure_settings of `qc`, and the
    robot profile's name."""
    text = json.dumps({"qc": measure_settings(qc), "robot": profile}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def content_digest(config: Config) -> str:
    """What a take's content was built with: the CONTENT_SECTIONS, and build.people when it is
    not the default (the one build key that changes what a take holds; so datasets built with
    the default keep their digest)."""
    digest = config.digest(*CONTENT_SECTIONS)
    if config.build.people == "speaker":
        return digest
    return hashlib.sha256(f"{digest} people={config.build.people}".encode()).hexdigest()[:16]


# Config sections that change what a take contains. The others only change how it is built
# (build), judged (qc), split (splits), calibrated (board), trained on (train), played
# (playback) or drawn (render, synth); speech sets each clip's `speech` and cuts long silences;
# tests/datasets/test_build.py checks each is one or the other.
NOT_CONTENT_SECTIONS = (
    "build",
    "qc",
    "splits",
    "board",
    "train",
    "playback",
    "render",
    "synth",
)


CONTENT_SECTIONS = (
    "video",
    "detector",
    "shots",
    "tracking",
    "repair",
    "clips",
    "lifter",
    "robot",
    "retarget",
    "processing",
    "audio",
    "mocap",
    "speech",
)
