"""Which trials a perceptual study has, read from a study folder, and each participant's order.

A study folder is what `gesturebank stimuli … --out study/` writes (`gesturebank.study.stimuli`
documents the formats): `stimuli.json`, the blind manifest (groups of videos by speech source),
and `key.json`, the operator's (id → condition and role: model, reference, anchor). Optionally
`design.toml` (`DesignFile`, checked: a wrong key or type is a one-line error naming the file):
what the consent page tells participants (`title`, `researcher`, `contact`, `ethics_reference`,
`consent_text`, `data_use`) and the trials: `ab = true`, `mushra = true`, `ab_question = "…"`,
and `[mushra_questions]` `id = "text"` (one slider per question and video; default one
question, appropriateness).

Trials, derived from those: for each speech source, one MUSHRA page (the ground truth labelled
as the reference on top when there is one, and every video of that source below it, the hidden
reference and the anchor among them) and one A/B trial per pair of its models (neither the
reference nor the anchor).
"""

from __future__ import annotations

import difflib
import json
import math
import random
import tomllib
from collections import defaultdict
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from gesturebank.errors import InputError
from gesturebank.study.stimuli import FORMAT, KEY, KEY_FORMAT, MANIFEST

DESIGN = "design.toml"
ROLES = ("model", "reference", "anchor")
DEFAULT_AB_QUESTION = "Which robot's movements fit the speech better?"
DEFAULT_MUSHRA_QUESTIONS = {
    "appropriate": "How appropriate are the movements for the speech?",
}
# The duration estimate the consent page gives (`estimated_minutes`), stated there as such.
VIEWS_PER_VIDEO = 2  # each video played twice: once to see it, once to compare
ANSWER_S = 10.0  # seconds to move one slider or pick one side
READING_S = 60.0  # this page and the instructions


class DesignFile(BaseModel):
    """design.toml. What participants are told is the researcher's to write; the page leaves
    out what is not given, and `study serve` says which of those an ethics board will ask for."""

    model_config = ConfigDict(extra="forbid")

    title: str = Field("A study of robot movements", min_length=1)
    researcher: str = Field("", description="who runs the study (name, institution)")
    contact: str = Field("", description="where participants write with questions")
    ethics_reference: str = Field("", description="the approval's reference number")
    consent_text: str = Field(
        "You will watch short videos of a robot moving while speech plays, and say which "
        "movements fit the speech better, or rate them. Taking part is voluntary: you can stop "
        "at any time by closing the page.",
        min_length=1,
    )
    data_use: str = Field(
        "We store only your answers, with a random number in place of your name; no name, "
        "e-mail or IP address is stored with them. The answers are analysed for research and "
        "may be published in anonymous form.",
        min_length=1,
    )
    ab: bool = True
    mushra: bool = True
    ab_question: str = Field(DEFAULT_AB_QUESTION, min_length=1)
    mushra_questions: dict[str, str] = Field(default_factory=lambda: dict(DEFAULT_MUSHRA_QUESTIONS))

    def missing(self) -> list[str]:
        """What an ethics board expects on the consent page and this file does not give."""
        return [k for k in ("researcher", "contact", "ethics_reference") if not getattr(self, k)]


def read_design_file(path: Path) -> DesignFile:
    """design.toml checked (defaults when absent); InputError in one line naming the file."""
    if not path.is_file():
        return DesignFile()
    try:
        options = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    try:
        found = DesignFile.model_validate(options)
    except ValidationError as exc:
        err = exc.errors()[0]
        where = ".".join(str(p) for p in err["loc"])
        if err["type"] == "extra_forbidden":
            near = difflib.get_close_matches(where, list(DesignFile.model_fields), n=1)
            hint = f" (did you mean {near[0]}?)" if near else ""
            raise InputError(f"{path}: unknown key {where!r}{hint}") from None
        raise InputError(f"{path}: {where}: {err['msg']}") from None
    for qid in found.mushra_questions:
        if not qid or not all(c.isascii() and (c.isalnum() or c in "_-") for c in qid):
            raise InputError(
                f"{path}: mushra_questions: id {qid!r} must be letters, digits, _ or -"
            )
    return found


@dataclass(frozen=True)
class Stimulus:
    id: str
    file: str
    audio: str
    duration_s: float
    model: str
    role: str  # "model", "reference" or "anchor"


@dataclass(frozen=True)
class Trial:
    id: str
    kind: str  # "ab" or "mushra"
    audio: str
    stimuli: tuple[str, ...]  # ab: the two compared; mushra: every rated stimulus
    reference: str | None = None  # mushra: the labelled reference shown on top


@dataclass(frozen=True)
class Design:
    folder: Path
    stimuli: dict[str, Stimulus]
    trials: dict[str, Trial]
    ab_question: str
    mushra_questions: dict[str, str]
    about: DesignFile  # what the consent page says

    def estimated_minutes(self) -> int:
        """Minutes the study takes, rounded up: every video of every page played
        VIEWS_PER_VIDEO times, ANSWER_S per answer, and READING_S for consent and instructions."""
        seconds = READING_S
        for trial in self.trials.values():
            shown = list(trial.stimuli) + ([trial.reference] if trial.reference else [])
            seconds += VIEWS_PER_VIDEO * sum(self.stimuli[s].duration_s for s in shown)
            answers = 1 if trial.kind == "ab" else len(trial.stimuli) * len(self.mushra_questions)
            seconds += ANSWER_S * answers
        return max(1, math.ceil(seconds / 60))


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: missing (write it with `gesturebank stimuli … --out`)") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON ({exc})") from None


def _stimuli(folder: Path) -> dict[str, Stimulus]:
    manifest, key = _read_json(folder / MANIFEST), _read_json(folder / KEY)
    for name, data, fmt in ((MANIFEST, manifest, FORMAT), (KEY, key, KEY_FORMAT)):
        if not isinstance(data, dict) or data.get("format") != fmt:
            raise InputError(f"{folder / name}: not a {fmt} file")
    found: dict[str, Stimulus] = {}
    for group in manifest.get("groups", []):
        for video in group.get("videos", []):
            sid = str(video.get("id", ""))
            entry = key["videos"].get(sid) if isinstance(key.get("videos"), dict) else None
            if entry is None or entry.get("role") not in ROLES:
                raise InputError(f"{folder / KEY}: no condition for video {sid!r} of {MANIFEST}")
            file = str(video.get("file", ""))
            path = (folder / file).resolve()
            if not path.is_relative_to(folder.resolve()) or not path.is_file():
                raise InputError(f"{folder / file}: the video of {sid!r} is missing")
            found[sid] = Stimulus(
                id=sid,
                file=file,
                audio=str(group.get("audio", "")),
                duration_s=float(group.get("duration_s", 0.0)),
                model=str(entry.get("condition", "")),
                role=str(entry["role"]),
            )
    if not found:
        raise InputError(f"{folder / MANIFEST}: lists no videos")
    return found


def load_design(folder: Path) -> Design:
    """The study in `folder`: its stimuli (with the key's models) and its trials."""
    stimuli = _stimuli(folder)
    about = read_design_file(folder / DESIGN)
    questions = dict(about.mushra_questions)
    trials: dict[str, Trial] = {}
    for audio in sorted({s.audio for s in stimuli.values()}):
        # by model: an A/B pair's first side is the same model for every audio
        of_audio = sorted(
            (s for s in stimuli.values() if s.audio == audio), key=lambda s: (s.model, s.id)
        )
        models = [s.id for s in of_audio if s.role == "model"]
        refs = [s.id for s in of_audio if s.role == "reference"]
        if about.mushra and questions and len(of_audio) > 1:
            tid = f"mushra-{audio}"
            ref = refs[0] if refs else None
            trials[tid] = Trial(tid, "mushra", audio, tuple(s.id for s in of_audio), ref)
        if about.ab:
            for a, b in combinations(models, 2):
                tid = f"ab-{audio}-{a}-{b}"
                trials[tid] = Trial(tid, "ab", audio, (a, b))
    if not trials:
        raise InputError(f"{folder}: the stimuli make no trial (need 2 models of one audio)")
    return Design(
        folder=folder,
        stimuli=stimuli,
        trials=trials,
        ab_question=about.ab_question,
        mushra_questions=questions,
        about=about,
    )


def participant_order(*, design: Design, seed: int, number: int) -> list[dict[str, Any]]:
    """The trials in the order one participant sees them, each with its stimuli in display
    order. Random (from `seed`) but counterbalanced: an A/B pair's sides flip with the
    participant's `number` (and alternate over the trials), so consecutive participants see
    every pair both ways."""
    rng = random.Random(seed)
    ids = sorted(design.trials)
    rng.shuffle(ids)
    # The k-th trial of each model pair (in a fixed order, not the shuffle) shows the pair
    # one way when k + number is even, the other way when odd.
    rank: dict[str, int] = {}
    pairs: dict[tuple[str, ...], int] = defaultdict(int)
    for tid in sorted(design.trials):
        models = tuple(design.stimuli[s].model for s in design.trials[tid].stimuli)
        rank[tid], pairs[models] = pairs[models], pairs[models] + 1
    order = []
    for tid in ids:
        trial = design.trials[tid]
        items = list(trial.stimuli)
        if trial.kind == "ab":
            if (rank[tid] + number) % 2:
                items.reverse()
        else:
            rng.shuffle(items)
        order.append({"trial": tid, "items": items})
    return order
