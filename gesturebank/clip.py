"""`Clip`: the unit of the dataset (docs/architecture.md "The dataset on disk") — one contiguous
span of a take,
one shot, one main speaker — with the arrays of one `takes/<take_id>/<clip_id>.npz`.

Every clip is on its own clock: `times` (the 100 Hz frame clock of angles and audio features)
starts at 0, `timestamps` (the video frames the clip was made from) are on the same clock, and
`start_s` says where clip time 0 lies in the source video. Nothing is pickled: strings are 0-d
unicode arrays, masks are bool arrays.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from gesturebank.errors import InputError
from gesturebank.poses import Pose2D, Pose3D
from gesturebank.robot.pepper import JOINTS
from gesturebank.skeletons import COCO17


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
        partner_speaking (N,) bool, the partner clip's person is speaking at times[i] (all
                  False without a partner; `datasets.partners`)
    Video frames (T frames):
        raw_angles (T, 11) float32 rad, straight from the 3D pose (NaN where unsupported)
        timestamps (T,) float64 seconds on the clip's clock
        pose2d, pose3d   the repaired main speaker (Pose2D, Pose3D on the clip's clock)
        valid     (T, 17) bool: COCO-17 keypoint seen (confident) after repair
        repaired  (T, 17) bool: COCO-17 keypoint changed by the repair
        n_people  (T,) int16: people the detector saw in the frame
        change    (T,) float32: image change vs the previous frame (shot detector), NaN unknown
    start_s: where clip time 0 lies in the source video, seconds.
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
    partner_clip_id: str
    partner_speaking: np.ndarray

    def __post_init__(self) -> None:
        n, t, d = len(self.times), len(self.timestamps), len(JOINTS)
        shapes = {
            "angles": (self.angles, (n, d)),
            "angles01": (self.angles01, (n, d)),
            "mask": (self.mask, (n, d)),
            "speech": (self.speech, (n,)),
            "partner_speaking": (self.partner_speaking, (n,)),
            "raw_angles": (self.raw_angles, (t, d)),
            "valid": (self.valid, (t, len(COCO17))),
            "repaired": (self.repaired, (t, len(COCO17))),
            "n_people": (self.n_people, (t,)),
            "change": (self.change, (t,)),
        }
        for name, (value, shape) in shapes.items():
            if np.shape(value) != shape:
                raise InputError(
                    f"clip {self.clip_id}: {name} must be {shape}, got {np.shape(value)}"
                )
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
                partner_clip_id=str(arrays["partner_clip_id"]),
                partner_speaking=np.asarray(arrays["partner_speaking"]),
            )
        except KeyError as exc:
            raise InputError(f"clip arrays lack {exc.args[0]!r}") from None
