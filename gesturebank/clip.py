"""`Clip`: the unit of the dataset (docs/architecture.md "The dataset on disk") — one contiguous
span of a take,
one shot, one main speaker — with the arrays of one `takes/<take_id>/<clip_id>.npz`.

A clip holds the body parts (`PARTS`: head, left arm, right arm) seen well enough; a part that
was not has its angles masked whole (`mask` False, `angles` NaN), and `parts_of(mask)` names the
parts a clip has with a label of `PART_LABELS` ("head", "arms", "head+left_arm", ...), the
manifest's `parts` column.

Every clip is on its own clock: `times` (the 100 Hz frame clock of angles and audio features)
starts at 0, `timestamps` (the video frames the clip was made from) are on the same clock, and
`start_s` says where clip time 0 lies in the source video. Nothing is pickled: strings are 0-d
unicode arrays, masks are bool arrays.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from gesturebank.errors import InputError
from gesturebank.poses import Pose2D, Pose3D
from gesturebank.robot.pepper import INDEX, JOINTS
from gesturebank.skeletons import COCO17

# The role track's codes, in order: 0 unknown (who speaks is not known: no mouth seen, or
# nobody's mouth follows the speech), 1 speaking, 2 listening (extract.roles).
ROLES = ("unknown", "speaking", "listening")
# Where a video frame's head angles came from, in order: 0 none (the head unknown), 1 the face
# mesh fitted to the reference face, 2 the body's face keypoints (`datasets.head`).
HEAD_SOURCES = ("none", "face", "body")
# Body parts, each judged on its own (issue 32): the Pepper joints that belong to it. HipRoll is
# the torso's, which every angle needs, and belongs to none.
PARTS = ("head", "left_arm", "right_arm")
PART_JOINTS: dict[str, tuple[str, ...]] = {
    "head": ("HeadPitch", "HeadYaw"),
    "left_arm": ("LShoulderRoll", "LShoulderPitch", "LElbowRoll", "LElbowYaw"),
    "right_arm": ("RShoulderRoll", "RShoulderPitch", "RElbowRoll", "RElbowYaw"),
}
# The COCO-17 keypoints only one part's angles need (`robot.retarget.NEEDS`): a part masked
# whole takes them out of the QC's judgement too (its arm's bones, spikes and swaps).
PART_KEYPOINTS: dict[str, tuple[str, ...]] = {
    "head": ("nose", "left_eye", "right_eye", "left_ear", "right_ear"),
    "left_arm": ("left_elbow", "left_wrist"),
    "right_arm": ("right_elbow", "right_wrist"),
}
# The closed vocabulary of the manifest's `parts`: every set of parts, named once; both arms are
# "arms". "none" (no part seen well enough) belongs to rejected clips only.
PART_LABELS: dict[frozenset[str], str] = {
    frozenset(): "none",
    frozenset({"head"}): "head",
    frozenset({"left_arm"}): "left_arm",
    frozenset({"right_arm"}): "right_arm",
    frozenset({"left_arm", "right_arm"}): "arms",
    frozenset({"head", "left_arm"}): "head+left_arm",
    frozenset({"head", "right_arm"}): "head+right_arm",
    frozenset({"head", "left_arm", "right_arm"}): "head+arms",
}
_LABEL_PARTS = {label: parts for parts, label in PART_LABELS.items()}


def parts_label(parts: Iterable[str]) -> str:
    """The manifest label of a set of `PARTS`: {"head", "left_arm"} → "head+left_arm"."""
    key = frozenset(parts)
    if key not in PART_LABELS:
        raise InputError(f"unknown body parts {sorted(key - set(PARTS))} (parts are {PARTS})")
    return PART_LABELS[key]


def parse_parts(label: str) -> frozenset[str]:
    """The parts a label names: one of `PART_LABELS`' labels, or parts joined by "+" in any
    order ("arms+head" = "head+arms"); InputError naming the vocabulary otherwise."""
    if label in _LABEL_PARTS:
        return _LABEL_PARTS[label]
    words = [w.strip() for w in label.split("+")]
    named = {w for w in words if w != "arms"} | (
        {"left_arm", "right_arm"} if "arms" in words else set()
    )
    if not words or not named <= set(PARTS) or "none" in words:
        known = ", ".join(label for label in _LABEL_PARTS if label != "none")
        raise InputError(f"body parts {label!r}: not one of {known}")
    return frozenset(named)


def part_columns(part: str) -> list[int]:
    """Columns of `part`'s joints in the (N, 11) angle arrays."""
    return [INDEX[j] for j in PART_JOINTS[part]]


def parts_of(mask: np.ndarray) -> frozenset[str]:
    """The parts with some known angle in `mask (N, 11)` (a part masked whole has none)."""
    known = np.asarray(mask, dtype=bool)
    return frozenset(p for p in PARTS if known[:, part_columns(p)].any())


def part_unknown(mask: np.ndarray) -> dict[str, float]:
    """Share of the clock `mask (N, 11)` (True = known) in which no angle of each part is known."""
    known = np.asarray(mask, dtype=bool)
    if not len(known):
        return dict.fromkeys(PARTS, 1.0)
    return {p: float(np.mean(~known[:, part_columns(p)].any(axis=1))) for p in PARTS}


def kept_parts(mask: np.ndarray, *, max_part_unseen_fraction: float) -> frozenset[str]:
    """The parts unknown in at most `max_part_unseen_fraction` of the clock `mask (N, 11)`."""
    unknown = part_unknown(mask)
    return frozenset(p for p in PARTS if unknown[p] <= max_part_unseen_fraction)


def part_mask(parts: Iterable[str]) -> np.ndarray:
    """(11,) bool: the joints of `parts`, and HipRoll (the torso's, in every part)."""
    keep = np.zeros(len(JOINTS), dtype=bool)
    keep[INDEX["HipRoll"]] = True
    for p in parts:
        keep[part_columns(p)] = True
    return keep


@dataclass(frozen=True, eq=False)
class Clip:
    """The arrays of one clip.

    100 Hz clock (N frames):
        angles    (N, 11) float32 rad, smoothed and clamped; NaN where a limb is unseen
        angles01  (N, 11) float32 in [0, 1] (Eq. 3.13–3.14); NaN where `angles` is
        mask      (N, 11) bool, True where the angle is known
        audio     (N, F) float32 audio features, frame i centred on times[i]
        times     (N,) float64 seconds from the clip's start
        speech    (N,) bool, speech heard at times[i] (voice activity; missing audio is silence)
        role      (N,) int8, the person's role at times[i]: an index into ROLES
        head_roll (N,) float32 rad, the head's roll about its forward axis (+ = left ear up; Pepper
                  has no such joint, seeds 002/004 use it), NaN where the head is unknown
        partner_speaking (N,) bool, the partner clip's person is speaking at times[i] (all
                  False without a partner; `datasets.partners`)
    Video frames (T frames):
        raw_angles (T, 11) float32 rad, straight from the 3D pose (NaN where unsupported)
        timestamps (T,) float64 seconds on the clip's clock
        pose2d, pose3d   the repaired main speaker (Pose2D, Pose3D on the clip's clock)
        valid     (T, 17) bool: COCO-17 keypoint seen (inside the image, confident) after repair
        repaired  (T, 17) bool: COCO-17 keypoint changed by the repair
        n_people  (T,) int16: people the detector saw in the frame
        change    (T,) float32: image change vs the previous frame (shot detector), NaN unknown
        depth_confidence (T,) float32 in [0, 1]: how far the lift's depth signs can be trusted
                  (`lift.depth_confidence`, Eq. 2; 1 where the 3D was measured: several cameras,
                  motion capture)
        head_source (T,) int8: where the frame's head angles came from, an index into
                  HEAD_SOURCES
    start_s: where clip time 0 lies in the source video, seconds.
    person: the tracked person's id within the take (>= 0; 0 for a motion-capture take).
    partner_clip_id: the clip of another person of the same take that overlaps this one in time
        (the listener of a speaker, or the speaker of a listener), "" when none.
    """

    clip_id: str
    take_id: str
    start_s: float
    angles: np.ndarray
    angles01: np.ndarray
    mask: np.ndarray
    audio: np.ndarray
    times: np.ndarray
    speech: np.ndarray
    raw_angles: np.ndarray
    timestamps: np.ndarray
    pose2d: Pose2D
    pose3d: Pose3D
    valid: np.ndarray
    repaired: np.ndarray
    n_people: np.ndarray
    change: np.ndarray
    head_roll: np.ndarray
    depth_confidence: np.ndarray
    partner_clip_id: str
    partner_speaking: np.ndarray
    person: int = 0
    role: np.ndarray | None = None
    head_source: np.ndarray | None = None

    def __post_init__(self) -> None:
        n, t, d = len(self.times), len(self.timestamps), len(JOINTS)
        if self.role is None:  # an older clip: who speaks was not known
            object.__setattr__(self, "role", np.zeros(n, np.int8))
        if self.head_source is None:  # built in memory without it: the head's source unknown
            object.__setattr__(self, "head_source", np.zeros(t, np.int8))
        shapes = {
            "angles": (self.angles, (n, d)),
            "angles01": (self.angles01, (n, d)),
            "mask": (self.mask, (n, d)),
            "speech": (self.speech, (n,)),
            "head_roll": (self.head_roll, (n,)),
            "partner_speaking": (self.partner_speaking, (n,)),
            "raw_angles": (self.raw_angles, (t, d)),
            "valid": (self.valid, (t, len(COCO17))),
            "repaired": (self.repaired, (t, len(COCO17))),
            "n_people": (self.n_people, (t,)),
            "change": (self.change, (t,)),
            "depth_confidence": (self.depth_confidence, (t,)),
            "role": (np.asarray(self.role), (n,)),
            "head_source": (np.asarray(self.head_source), (t,)),
        }
        for name, (value, shape) in shapes.items():
            if np.shape(value) != shape:
                raise InputError(
                    f"clip {self.clip_id}: {name} must be {shape}, got {np.shape(value)}"
                )
        confidence = np.asarray(self.depth_confidence)
        if confidence.dtype != np.float32 or not ((confidence >= 0) & (confidence <= 1)).all():
            raise InputError(
                f"clip {self.clip_id}: depth_confidence must be float32 in [0, 1] (no NaN), got "
                f"{confidence.dtype} in [{np.nanmin(confidence, initial=0):.3g}, "
                f"{np.nanmax(confidence, initial=1):.3g}]"
            )
        role = np.asarray(self.role)
        if role.dtype != np.int8 or (len(role) and (role.min() < 0 or role.max() >= len(ROLES))):
            raise InputError(
                f"clip {self.clip_id}: role must be int8 codes 0..{len(ROLES) - 1} (ROLES), "
                f"got {role.dtype}"
            )
        source = np.asarray(self.head_source)
        if source.dtype != np.int8 or (
            len(source) and (source.min() < 0 or source.max() >= len(HEAD_SOURCES))
        ):
            raise InputError(
                f"clip {self.clip_id}: head_source must be int8 codes 0..{len(HEAD_SOURCES) - 1} "
                f"(HEAD_SOURCES), got {source.dtype}"
            )
        if int(self.person) < 0:
            raise InputError(f"clip {self.clip_id}: person must be >= 0, got {self.person}")
        if np.asarray(self.head_roll).dtype != np.float32:
            raise InputError(
                f"clip {self.clip_id}: head_roll must be float32, "
                f"got {np.asarray(self.head_roll).dtype}"
            )
        head = np.asarray(self.mask, dtype=bool)[:, part_columns("head")].any(axis=1)
        if np.isfinite(np.asarray(self.head_roll)[~head]).any():
            raise InputError(f"clip {self.clip_id}: head_roll known where the head is not")
        for name in ("speech", "partner_speaking"):
            dtype = np.asarray(getattr(self, name)).dtype
            if dtype != np.bool_:
                raise InputError(f"clip {self.clip_id}: {name} must be bool, got {dtype}")
        if self.partner_clip_id == self.clip_id:
            raise InputError(f"clip {self.clip_id}: a clip cannot be its own partner")
        if not self.partner_clip_id and np.any(self.partner_speaking):
            raise InputError(f"clip {self.clip_id}: partner_speaking is set but it has no partner")
        if np.ndim(self.audio) != 2 or len(self.audio) != n:
            raise InputError(f"clip {self.clip_id}: audio must be (N, F) with N = {n}")
        if len(self.pose2d) != t or len(self.pose3d) != t:
            raise InputError(f"clip {self.clip_id}: poses must have one frame per timestamp")

    @property
    def speaking_fraction(self) -> float:
        """Share of the clip's frames in which its person speaks."""
        return (
            float(np.mean(np.asarray(self.role) == ROLES.index("speaking")))
            if len(self.times)
            else 0.0
        )

    @property
    def duration_s(self) -> float:
        """Seconds of the 100 Hz clock: N frames of one hop each."""
        hop = float(np.median(np.diff(self.times))) if len(self.times) > 1 else 0.01
        return len(self.times) * hop

    def to_arrays(self) -> dict[str, np.ndarray]:
        return {
            "clip_id": np.array(self.clip_id),
            "take_id": np.array(self.take_id),
            "start_s": np.array(self.start_s, dtype=np.float64),
            "angles": np.asarray(self.angles, dtype=np.float32),
            "angles01": np.asarray(self.angles01, dtype=np.float32),
            "mask": np.asarray(self.mask, dtype=bool),
            "audio": np.asarray(self.audio, dtype=np.float32),
            "times": np.asarray(self.times, dtype=np.float64),
            "speech": np.asarray(self.speech, dtype=bool),
            "raw_angles": np.asarray(self.raw_angles, dtype=np.float32),
            "timestamps": np.asarray(self.timestamps, dtype=np.float64),
            "valid": np.asarray(self.valid, dtype=bool),
            "repaired": np.asarray(self.repaired, dtype=bool),
            "n_people": np.asarray(self.n_people, dtype=np.int16),
            "change": np.asarray(self.change, dtype=np.float32),
            "depth_confidence": np.asarray(self.depth_confidence, dtype=np.float32),
            "person": np.array(self.person, dtype=np.int32),
            "role": np.asarray(self.role, dtype=np.int8),
            "head_source": np.asarray(self.head_source, dtype=np.int8),
            "head_roll": np.asarray(self.head_roll, dtype=np.float32),
            "partner_clip_id": np.array(self.partner_clip_id),
            "partner_speaking": np.asarray(self.partner_speaking, dtype=bool),
            **self.pose2d.to_arrays("pose2d_"),
            **self.pose3d.to_arrays("pose3d_"),
        }

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> Clip:
        try:
            return cls(
                clip_id=str(arrays["clip_id"]),
                take_id=str(arrays["take_id"]),
                start_s=float(arrays["start_s"]),
                angles=np.asarray(arrays["angles"]),
                angles01=np.asarray(arrays["angles01"]),
                mask=np.asarray(arrays["mask"]),
                audio=np.asarray(arrays["audio"]),
                times=np.asarray(arrays["times"]),
                speech=np.asarray(arrays["speech"]),
                raw_angles=np.asarray(arrays["raw_angles"]),
                timestamps=np.asarray(arrays["timestamps"]),
                pose2d=Pose2D.from_arrays(arrays, "pose2d_"),
                pose3d=Pose3D.from_arrays(arrays, "pose3d_"),
                valid=np.asarray(arrays["valid"]),
                repaired=np.asarray(arrays["repaired"]),
                n_people=np.asarray(arrays["n_people"]),
                change=np.asarray(arrays["change"]),
                depth_confidence=np.asarray(arrays["depth_confidence"]),
                person=int(arrays["person"]) if "person" in arrays else 0,
                role=np.asarray(arrays["role"]) if "role" in arrays else None,
                head_source=np.asarray(arrays["head_source"]),
                head_roll=np.asarray(arrays["head_roll"]),
                partner_clip_id=str(arrays["partner_clip_id"]),
                partner_speaking=np.asarray(arrays["partner_speaking"]),
            )
        except KeyError as exc:
            raise InputError(f"clip arrays lack {exc.args[0]!r}") from None
