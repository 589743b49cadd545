"""The dataset on disk (docs/architecture.md "The dataset on disk"), schema 4: clips, written take
by take.

    out/dataset.json              `DatasetInfo`: schema version, tool version, resolved config,
                                  joints, limits, rates, audio features, normalisation, per-take
                                  summary (clips, usable seconds, share kept)
    out/DATASET.md                the dataset card (`datasets.card`), rewritten with dataset.json
    out/manifest.parquet          one row per clip and per dropped span (`MANIFEST_SCHEMA`)
    out/takes/<take_id>.json      the take's record (`TakeRecord`, its clips and dropped spans);
                                  written last, so it marks a take as done
    out/takes/<take_id>/<clip_id>.npz   the arrays of one clip (`gesturebank.clip.Clip`)
    out/takes/<take_id>/preview.jpg     a strip of video frames for the dashboard

A take's clips are written into a hidden temporary folder that replaces the take's folder when
complete, then the record is written (atomically): a killed build never leaves a half-written
take under its final name, and a take whose record carries the current config digest is
"built" and skipped on a re-run. Failed takes are retried. The manifest is consolidated from the
per-take records, which is also how Ray workers hand back results. Nothing is ever unpickled.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pyarrow as pa
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from gesturebank.clip import Clip, parts_label, parts_of
from gesturebank.config import Config
from gesturebank.errors import InputError
from gesturebank.fileio import write_bytes_atomic
from gesturebank.robot.pepper import JOINTS

# 5: every clip holds `head_source` (per video frame: the face mesh or the body's keypoints);
# 4: every clip holds `depth_confidence` (per video frame), its person and role track (who
# speaks when), `head_roll`, its partner (`partner_clip_id`, `partner_speaking`), and is judged
# by body part; the manifest gains `depth_confidence`, `expected_hand_error_cm`, `person`,
# `speaking_fraction`, `parts` and `partner_clip_id`; 3: every clip holds `speech` (100 Hz
# voice activity); 2: clips; 1: one unit per video.
SCHEMA_VERSION = 5
# what this version holds, in the refusal
SCHEMA_CONTENT = (
    "clips with speech activity, depth confidence, body parts and head roll, "
    "each clip one person's with its role track, paired with their partner's clip, "
    "and where each frame's head came from"
)
DATASET_JSON = "dataset.json"
MANIFEST = "manifest.parquet"
TAKES_DIR = "takes"
CHUNKS_DIR = ".detections"  # detections of long videos' chunks (extract.chunks), kept for reruns
PREVIEW = "preview.jpg"

Status = Literal["accepted", "rejected", "failed"]
STATUSES: tuple[Status, ...] = ("accepted", "rejected", "failed")
# Manifest columns copied from a clip's metrics (null for a span, or where not measured or NaN).
DEPTH_COLUMNS = ("depth_confidence", "expected_hand_error_cm")
Kind = Literal["clip", "span"]  # a clip has arrays; a span is time that gave none (dropped, failed)

# Manifest columns every reader can rely on (more may follow; none is ever renamed).
MANIFEST_SCHEMA = pa.schema(
    [
        ("clip_id", pa.string()),
        ("take_id", pa.string()),
        ("kind", pa.string()),
        ("subject", pa.string()),
        ("source", pa.string()),
        ("start_s", pa.float64()),
        ("end_s", pa.float64()),
        ("duration_s", pa.float64()),
        ("n_frames", pa.int64()),
        ("video_fps", pa.float64()),
        ("detector", pa.string()),
        ("lifter", pa.string()),
        ("qc_status", pa.string()),
        ("qc_reasons", pa.list_(pa.string())),
        ("metrics", pa.map_(pa.string(), pa.float64())),
        ("repairs", pa.map_(pa.string(), pa.int64())),
        ("masked", pa.map_(pa.string(), pa.float64())),
        ("config_digest", pa.string()),
        ("traits", pa.map_(pa.string(), pa.string())),
        # the clip's mean depth confidence and the hand error it predicts (its metrics' values)
        ("depth_confidence", pa.float64()),
        ("expected_hand_error_cm", pa.float64()),
        ("person", pa.int32()),
        ("speaking_fraction", pa.float64()),
        ("parts", pa.string()),
        ("partner_clip_id", pa.string()),
    ]
)


# --------------------------------------------------------------------------------------------------
# Records


@dataclass(frozen=True)
class ClipRecord:
    """One clip of a take, or one span of it that gave no clip (kind "span", with its reason).

    start_s, end_s: the span in the source video, seconds. duration_s: seconds of the clip's
    100 Hz clock (n_frames frames). repairs: what the repair changed (counts). masked: share of
    the clip's frames where each Pepper joint is unknown. measured: digest of the QC settings the
    metrics were measured with (so `refresh` knows when to measure again). person: the
    tracked person's id within the take (-1: a span, nobody's); speaking_fraction: share of
    the clip's frames in which that person speaks (role "speaking"; 0 for a span). parts: the
    body parts the clip has (`clip.PART_LABELS`: "head", "arms", "head+left_arm", ...; "" for
    a span). partner_clip_id: the clip's partner (`datasets.partners`), "" when none.
    """

    clip_id: str
    kind: Kind
    start_s: float
    end_s: float
    qc_status: Status
    qc_reasons: tuple[str, ...] = ()
    duration_s: float = 0.0
    n_frames: int = 0
    metrics: Mapping[str, float] = field(default_factory=dict)
    repairs: Mapping[str, int] = field(default_factory=dict)
    masked: Mapping[str, float] = field(default_factory=dict)
    measured: str = ""
    person: int = 0
    speaking_fraction: float = 0.0
    parts: str = ""
    partner_clip_id: str = ""

    def __post_init__(self) -> None:
        if self.person < (0 if self.kind == "clip" else -1):
            raise ValueError(f"clip {self.clip_id}: person must be >= 0, got {self.person}")
        if not 0.0 <= self.speaking_fraction <= 1.0:
            raise ValueError(
                f"clip {self.clip_id}: speaking_fraction must be in [0, 1], "
                f"got {self.speaking_fraction}"
            )
        if self.qc_status not in STATUSES:
            raise ValueError(f"qc_status must be one of {STATUSES}, got {self.qc_status!r}")
        if self.kind not in ("clip", "span"):
            raise ValueError(f"kind must be 'clip' or 'span', got {self.kind!r}")

    @classmethod
    def of_clip(
        cls, clip: Clip, *, metrics: Mapping[str, float], reasons: Sequence[str], measured: str
    ) -> ClipRecord:
        """The record of a clip the builder judged: its QC verdict from `reasons`, its
        `metrics`, and what the clip itself says (span, repairs, masked shares, parts, person,
        partner)."""
        return cls(
            clip_id=clip.clip_id,
            kind="clip",
            start_s=clip.start_s,
            end_s=clip.start_s + clip.duration_s,
            qc_status="rejected" if reasons else "accepted",
            qc_reasons=tuple(reasons),
            duration_s=clip.duration_s,
            n_frames=len(clip.times),
            metrics=dict(metrics),
            repairs={
                "keypoints": int(clip.repaired.sum()),
                "frames": int(clip.repaired.any(axis=1).sum()),
            },
            masked={j: float(np.mean(~clip.mask[:, i])) for i, j in enumerate(JOINTS)},
            parts=parts_label(parts_of(clip.mask)),
            measured=measured,
            person=clip.person,
            speaking_fraction=clip.speaking_fraction,
            partner_clip_id=clip.partner_clip_id,
        )

    def to_json_dict(self) -> dict[str, Any]:
        return {
            "clip_id": self.clip_id,
            "kind": self.kind,
            "start_s": float(self.start_s),
            "end_s": float(self.end_s),
            "qc_status": self.qc_status,
            "qc_reasons": list(self.qc_reasons),
            "duration_s": float(self.duration_s),
            "n_frames": int(self.n_frames),
            "metrics": {k: float(v) for k, v in self.metrics.items()},
            "repairs": {k: int(v) for k, v in self.repairs.items()},
            "masked": {k: float(v) for k, v in self.masked.items()},
            "measured": self.measured,
            "person": int(self.person),
            "speaking_fraction": float(self.speaking_fraction),
            "parts": self.parts,
            "partner_clip_id": self.partner_clip_id,
        }

    @classmethod
    def from_json_dict(cls, d: Mapping[str, Any]) -> ClipRecord:
        return cls(
            clip_id=d["clip_id"],
            kind=d["kind"],
            start_s=float(d["start_s"]),
            end_s=float(d["end_s"]),
            qc_status=d["qc_status"],
            qc_reasons=tuple(d.get("qc_reasons", ())),
            duration_s=float(d.get("duration_s", 0.0)),
            n_frames=int(d.get("n_frames", 0)),
            metrics=dict(d.get("metrics", {})),
            repairs=dict(d.get("repairs", {})),
            masked=dict(d.get("masked", {})),
            measured=str(d.get("measured", "")),
            person=int(d["person"] if d.get("person") is not None else 0),
            speaking_fraction=float(d.get("speaking_fraction") or 0.0),
            parts=str(d.get("parts") or ""),
            partner_clip_id=str(d.get("partner_clip_id") or ""),
        )


@dataclass(frozen=True)
class TakeRecord:
    """What one take gave: its clips and dropped spans, or the reason it failed.

    seconds: time of the take that was looked at (the used range of the video); visible_s: the
    seconds in which the main speaker was seen; tracking: the main-speaker report (JSON); audio:
    per-feature sums over every clip frame ({"n", "sum", "sumsq"}), for the z-normalisation
    stats; preview_times: source times of the frames in preview.jpg.
    """

    take_id: str
    subject: str
    source: str
    config_digest: str
    failed: str = ""  # the one-line reason when the take failed as a whole
    detector: str = ""
    lifter: str = ""
    video_fps: float = float("nan")
    seconds: float = 0.0
    visible_s: float = 0.0
    clips: tuple[ClipRecord, ...] = ()
    tracking: Mapping[str, Any] = field(default_factory=dict)
    audio: Mapping[str, Any] = field(default_factory=dict)
    preview_times: tuple[float, ...] = ()
    traits: Mapping[str, str] = field(default_factory=dict)

    @property
    def data_clips(self) -> tuple[ClipRecord, ...]:
        """The clips that have arrays on disk."""
        return tuple(c for c in self.clips if c.kind == "clip")

    @property
    def usable_s(self) -> float:
        """Seconds in accepted clips."""
        return float(sum(c.duration_s for c in self.clips if c.qc_status == "accepted"))

    def to_json_dict(self) -> dict[str, Any]:
        return {
            "take_id": self.take_id,
            "subject": self.subject,
            "source": self.source,
            "config_digest": self.config_digest,
            "failed": self.failed,
            "detector": self.detector,
            "lifter": self.lifter,
            "video_fps": float(self.video_fps),
            "seconds": float(self.seconds),
            "visible_s": float(self.visible_s),
            "clips": [c.to_json_dict() for c in self.clips],
            "tracking": dict(self.tracking),
            "audio": dict(self.audio),
            "preview_times": [float(t) for t in self.preview_times],
            "traits": dict(self.traits),
        }

    @classmethod
    def from_json_dict(cls, d: Mapping[str, Any]) -> TakeRecord:
        return cls(
            take_id=d["take_id"],
            subject=d["subject"],
            source=d["source"],
            config_digest=d["config_digest"],
            failed=str(d.get("failed", "")),
            detector=d.get("detector", ""),
            lifter=d.get("lifter", ""),
            video_fps=float(d.get("video_fps", float("nan"))),
            seconds=float(d.get("seconds", 0.0)),
            visible_s=float(d.get("visible_s", 0.0)),
            clips=tuple(ClipRecord.from_json_dict(c) for c in d.get("clips", ())),
            tracking=dict(d.get("tracking", {})),
            audio=dict(d.get("audio", {})),
            preview_times=tuple(float(t) for t in d.get("preview_times", ())),
            traits=dict(d.get("traits", {})),
        )


# --------------------------------------------------------------------------------------------------
# dataset.json


class _Info(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Rates(_Info):
    pose_hz: float
    audio_hz: float


class AudioFeatures(_Info):
    kind: str
    dim: int
    params: dict[str, Any]
    frame_time: str = "window centre: start + i·winstep_s + winlen_s / 2"


class ZNorm(_Info):
    mean: list[float]
    std: list[float]


class TakeSummary(_Info):
    """One take in dataset.json: what it gave."""

    status: Literal["built", "failed"]
    clips: int = Field(description="Clips with arrays (accepted or rejected by the QC).")
    accepted: int
    seconds: float = Field(description="Seconds of the take that were looked at.")
    visible_s: float = Field(description="Seconds in which the main speaker was seen.")
    usable_s: float = Field(description="Seconds in accepted clips.")

    @property
    def kept_share(self) -> float:
        """Usable seconds over the seconds the speaker was visible (0 when never visible)."""
        return self.usable_s / self.visible_s if self.visible_s > 0 else 0.0


class DatasetInfo(_Info):
    """dataset.json: everything a reader needs besides the manifest and the arrays."""

    schema_version: int = SCHEMA_VERSION
    tool: str = "gesturebank"
    tool_version: str
    videos_dir: str
    config: Config
    config_digest: str
    joints: list[str]
    limits: dict[str, dict[str, float]]
    robot_profile: str
    rates: Rates
    audio_features: AudioFeatures
    audio_znorm_by_subject: dict[str, ZNorm] = Field(
        description="Per subject (and '*' for all) mean and std of every audio feature (§3.2)."
    )
    clip_counts: dict[str, int] = Field(description="Clips (with arrays) per QC status.")
    stretches_dropped: int = Field(
        0, description="Stretches of built takes that gave no clip (a span with its reason)."
    )
    takes: dict[str, TakeSummary]

    @property
    def usable_s(self) -> float:
        return float(sum(t.usable_s for t in self.takes.values()))

    @property
    def visible_s(self) -> float:
        return float(sum(t.visible_s for t in self.takes.values()))


def write_dataset_json(out: Path, info: DatasetInfo) -> None:
    write_bytes_atomic(Path(out) / DATASET_JSON, info.model_dump_json(indent=1).encode())


def read_dataset_json(out: Path) -> DatasetInfo:
    """The dataset's DatasetInfo; InputError with one line when missing, old or broken."""
    meta = Path(out) / DATASET_JSON
    try:
        raw = json.loads(meta.read_text())
    except FileNotFoundError:
        raise InputError(f"{meta}: not found — is {meta.parent} a gesturebank dataset?") from None
    except ValueError as exc:
        raise InputError(f"{meta}: not valid JSON ({exc})") from None
    version = raw.get("schema_version") if isinstance(raw, dict) else None
    if version != SCHEMA_VERSION:
        raise InputError(
            f"{meta}: schema_version {version}, this gesturebank reads {SCHEMA_VERSION} "
            f"({SCHEMA_CONTENT}): "
            f"rebuild it with build-dataset VIDEOS_DIR {meta.parent} --force"
        )
    try:
        return DatasetInfo.model_validate(raw)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise InputError(f"{meta}: {where}: {first['msg']}") from None


# --------------------------------------------------------------------------------------------------
# Where things are


def take_json(out: Path, take_id: str) -> Path:
    return Path(out) / TAKES_DIR / f"{take_id}.json"


def take_dir(out: Path, take_id: str) -> Path:
    return Path(out) / TAKES_DIR / take_id


def clip_npz(out: Path, *, take_id: str, clip_id: str) -> Path:
    return take_dir(out, take_id) / f"{clip_id}.npz"


# --------------------------------------------------------------------------------------------------
# Reading a clip (the one reader of a clip's .npz)


def read_clip_arrays(path: Path) -> dict[str, np.ndarray]:
    """All arrays of the clip file `path` as plain numpy (never unpickled); numpy's OSError or
    ValueError when it cannot be read (each caller words its own message)."""
    with np.load(path, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


def read_clip(path: Path) -> Clip:
    """The clip in the file `path`, typed (`read_clip_arrays`, then `Clip.from_arrays`)."""
    return Clip.from_arrays(read_clip_arrays(path))
