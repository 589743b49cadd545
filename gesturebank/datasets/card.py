"""The dataset card, OUT_DIR/DATASET.md: what a built dataset is made of and may be used for.

Its sources (each take's video, and the licence, consent and origin an optional
VIDEOS_DIR/takes.toml states for it), the seconds kept by subject, by body part and the seconds
not kept by reason, and the gesturebank version and config digest it was built with. Written by
`datasets.refresh` beside dataset.json, so `build-dataset` and `gesturebank qc` keep it current.

takes.toml holds one table per take id, every key optional:

    [alice-01]
    licence = "CC BY 4.0"
    consent = "signed release, 2026-03-02"
    source = "https://example.org/talks/alice-01"
"""

from __future__ import annotations

import tomllib
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

from pydantic import BaseModel, ConfigDict, ValidationError

from gesturebank.datasets.listing import PARTS
from gesturebank.datasets.records import DatasetInfo, TakeRecord
from gesturebank.errors import InputError
from gesturebank.fileio import write_bytes_atomic

CARD = "DATASET.md"
TAKES_TOML = "takes.toml"
NOT_STATED = "not stated"


class TakeTerms(BaseModel):
    """What takes.toml states about one take (a key it does not give is "not stated")."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    licence: str = NOT_STATED
    consent: str = NOT_STATED
    source: str = NOT_STATED


def read_takes_toml(videos_dir: Path) -> dict[str, TakeTerms]:
    """The terms of every take named in VIDEOS_DIR/takes.toml ({} when there is no such file);
    InputError with one line naming the file and the bad key or value."""
    path = Path(videos_dir) / TAKES_TOML
    if not path.is_file():
        return {}
    try:
        raw = tomllib.loads(path.read_text())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"{path}: not readable TOML ({exc})") from None
    terms = {}
    for take_id, table in raw.items():
        if not isinstance(table, dict):
            raise InputError(f"{path}: {take_id}: must be a table ([{take_id}]) of licence, …")
        try:
            terms[take_id] = TakeTerms.model_validate(table)
        except ValidationError as exc:
            first = exc.errors()[0]
            where = ".".join(str(p) for p in (take_id, *first["loc"]))
            raise InputError(f"{path}: {where}: {first['msg']}") from None
    return terms


def _cell(text: str) -> str:
    """Text safe inside a markdown table cell."""
    return " ".join(str(text).split()).replace("|", "\\|")


def _seconds_table(title: str, key: str, seconds: Mapping[str, float]) -> list[str]:
    lines = [f"## {title}", "", f"| {key} | seconds | hours |", "|---|---:|---:|"]
    for name, s in seconds.items():
        lines.append(f"| {_cell(name)} | {s:.1f} | {s / 3600:.3f} |")
    if not seconds:
        lines.append("| (none) | 0.0 | 0.000 |")
    return [*lines, ""]


def _span_seconds(clip_duration: float, start_s: float, end_s: float, kind: str) -> float:
    """A clip's seconds on its 100 Hz clock; a span (no arrays) its length in the video."""
    return clip_duration if kind == "clip" else max(end_s - start_s, 0.0)


def card_text(
    *, info: DatasetInfo, records: Sequence[TakeRecord], terms: Mapping[str, TakeTerms]
) -> str:
    """The dataset card (markdown) of a dataset with this dataset.json and these take records."""
    by_subject: dict[str, float] = defaultdict(float)
    by_part: dict[str, float] = dict.fromkeys(PARTS, 0.0)
    by_reason: dict[str, float] = defaultdict(float)
    for r in records:
        for c in r.clips:
            if c.qc_status == "accepted":
                by_subject[r.subject] += c.duration_s
                for part, joints in PARTS.items():
                    # the part counts as known where its most-masked joint is known
                    unknown = max(float(c.masked.get(j, 0.0)) for j in joints)
                    by_part[part] += c.duration_s * (1.0 - unknown)
            else:
                seconds = _span_seconds(c.duration_s, c.start_s, c.end_s, c.kind)
                for reason in c.qc_reasons or (c.qc_status,):
                    by_reason[reason] += seconds
    kept = sum(by_subject.values())
    lines = [
        "# Dataset card",
        "",
        f"Built by gesturebank {info.tool_version} (config digest `{info.config_digest}`, "
        f"robot profile {info.robot_profile}) from `{info.videos_dir}`.",
        "",
        f"Kept: {kept:.1f} s ({kept / 3600:.3f} h) in accepted clips, from {len(records)} takes; "
        f"clips kept {info.clip_counts.get('accepted', 0)}, "
        f"clips rejected {info.clip_counts.get('rejected', 0)}, "
        f"stretches dropped {info.stretches_dropped}.",
        "",
        "## Sources",
        "",
        f"Licence, consent and origin as {TAKES_TOML} in the videos folder states them.",
        "",
        "| take | subject | video | licence | consent | origin | kept s |",
        "|---|---|---|---|---|---|---:|",
    ]
    for r in records:
        t = terms.get(r.take_id, TakeTerms())
        cells = (r.take_id, r.subject, r.source, t.licence, t.consent, t.source)
        lines.append("| " + " | ".join(_cell(x) for x in cells) + f" | {r.usable_s:.1f} |")
    lines.append("")
    lines += _seconds_table("Kept by subject", "subject", dict(sorted(by_subject.items())))
    lines += _seconds_table(
        "Kept by body part (accepted seconds in which the part's joints are known)", "part", by_part
    )
    lines += _seconds_table(
        "Not kept, by reason (a clip with several reasons counts under each)",
        "reason",
        dict(sorted(by_reason.items())),
    )
    return "\n".join(lines)


def write_card(
    out: Path,
    *,
    info: DatasetInfo,
    records: Iterable[TakeRecord],
    terms: Mapping[str, TakeTerms],
) -> Path:
    """Write OUT/DATASET.md (atomically) for this dataset; returns its path."""
    text = card_text(info=info, records=list(records), terms=terms)
    path = Path(out) / CARD
    write_bytes_atomic(path, text.encode())
    return path
