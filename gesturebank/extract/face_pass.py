"""The face model over one pass of a video's frames: mouths and heads (issue 43).

`FacePass` is fed the frames the detector sees, with the people it found on each, either during
detection itself (`detect_people(on_people=...)`: no second decode) or from a second decode when
the detections came from the cache. It measures at most `speech.mouth_rate_hz` frames a second,
chosen on the detected frames' own timestamps (so 60 fps footage detected at 30 is measured at
15 Hz, not on the frames where the two rate caps happen to agree).

The mouth is read only where the speaker can be in doubt: where somebody else is in the picture
(`speech.mouths_alone` reads it on a face alone too). A face whose mouth is read is found afresh
on every sample, as before: the mouth on the crop placed from the body's face keypoints
(`extract.mouth.face_box`), the head once more on the crop that first mesh gives
(`head_pose.mesh_roi`). A face measured for its head alone is followed: its crop is the one
its mesh of the sample before gives, moved as the body's nose moved since, and one model pass
gives its head, as mediapipe's own face pipeline follows a face. It is found afresh (two passes)
where it was not measured on the sample before or where the model is unsure of it in the
followed crop (presence below FOLLOW_PRESENCE: somebody else, a cut). Mouth openings read on
followed crops followed the speech worse (the rendered conversation's second figure: 97 → 81 %
of frames), so mouths never come from them. A head never found yet is looked for less often
after three misses in a row (MISSES_BEFORE_BACKING_OFF).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from gesturebank.config import SpeechConfig
from gesturebank.extract.detectors.blazepose import Roi
from gesturebank.extract.head_pose import MIN_HEAD_PRESENCE, fit_head, head_box, mesh_roi
from gesturebank.extract.mouth import MIN_FACE_PRESENCE, FaceLandmarker, FaceMesh, face_box

# A face is followed from its mesh only while the model is sure of it (a crop from an unsure
# mesh drifts off the face); below, it is found afresh from the body's keypoints.
FOLLOW_PRESENCE = MIN_FACE_PRESENCE
# A track whose head has not been found yet, looked for and not found on this many samples in a
# row (a blurred or masked face, the back of a head the body calls a face), is looked for on one
# sample in RETRY_EVERY until it is found once; from then on on every sample, as before. (Backing
# off after any three misses lost face reads where a side view's face comes and goes: held-out
# test2 at 60°, 11 → 5 % of frames; this rule gave test.bvh at 60° the same heads.) On the
# talking demo's lab clip, whose face is pixelated, 2 passes a sample found a head on 1 of 107
# samples: ~5 % of the take, for nothing.
MISSES_BEFORE_BACKING_OFF = 3
RETRY_EVERY = 4
_MIN_STEP = 0.75  # as extract.video's rate cap: a sample when this share of 1 / rate has passed


@dataclass(frozen=True)
class FaceWork:
    """What the face pass measures: `speech` (face_box limits, mouth_rate_hz), whether mouths
    are read (`mouths`), the head's (largest turn, smallest width px) or None (no head), and
    whether a face alone in the picture gets its mouth read (`mouth_alone`,
    `speech.mouths_alone`)."""

    speech: SpeechConfig
    mouths: bool
    head_limits: tuple[float, float] | None
    mouth_alone: bool = True


@dataclass(frozen=True)
class SlotFace:
    """One face measured on one sampled frame: its slot in the frame; opening (NaN: no mouth);
    the head's axes (3, 3), centre (2,), residual (NaN: no head)."""

    slot: int
    opening: float
    axes: np.ndarray
    centre: np.ndarray
    residual: float


_NO_AXES = np.full((3, 3), np.nan)
_NO_CENTRE = np.full(2, np.nan)


def _inside(roi: Roi, point: tuple[float, float]) -> bool:
    return bool(np.hypot(point[0] - roi.cx, point[1] - roi.cy) <= roi.side / 2)


class FacePass:
    """The face model on a stream of detected frames (module docstring). Call it once per
    detected frame, in order; `rows` and `faces` are what it measured."""

    def __init__(self, work: FaceWork, *, skeleton: str) -> None:
        self.work = work
        self.skeleton = skeleton
        self.min_step = _MIN_STEP / work.speech.mouth_rate_hz
        self.last_t = -np.inf
        self.rows: list[int] = []  # the sampled frames' indices
        self.faces: list[list[SlotFace]] = []  # per sampled frame
        self.passes = 0  # face model passes (for the benchmarks)
        self.seconds = 0.0  # spent measuring (inside detection it is not the detector's time)
        self._model: FaceLandmarker | None = None
        # track key → (mesh points, the body's nose) of the last sample
        self._tracked: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        # track key → its samples since it was first looked for, while its head was never found
        # (a head alone, no mouth: MISSES_BEFORE_BACKING_OFF)
        self._misses: dict[int, int] = {}
        self._seen: set[int] = set()  # track keys whose head was found on some sample

    def wants(self, t: float) -> bool:
        """Whether the frame at `t` is sampled (without taking it)."""
        return t - self.last_t >= self.min_step

    def take(self, t: float) -> bool:
        """Whether the frame at `t` is sampled, taking it if so (the rate's clock moves on)."""
        if not self.wants(t):
            return False
        self.last_t = t
        return True

    def __call__(
        self,
        index: int,
        t: float,
        image: np.ndarray,
        keypoints: np.ndarray,
        keys: np.ndarray | None,
    ) -> None:
        """Frame `index` at `t`: RGB `image`, everybody's `keypoints (P, K, 3)` (NaN: an empty
        slot) and their track `keys (P,)` (-1: none; None: no tracks, nothing followed)."""
        if self.take(t):
            self.measure(index, image, keypoints, keys)

    def measure(
        self, index: int, image: np.ndarray, keypoints: np.ndarray, keys: np.ndarray | None
    ) -> None:
        """The faces of sampled frame `index` (`take`), as `__call__` says; called in the
        sampled frames' order."""
        start = time.perf_counter()
        kps = np.asarray(keypoints, np.float32)  # as the detections are stored
        present = [p for p in range(len(kps)) if np.isfinite(kps[p, :, 0]).any()]
        tracked: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        found: list[SlotFace] = []
        for p in present:
            key = -1 if keys is None else int(keys[p])
            face, follow = self._one(image, kps[p], key, alone=len(present) == 1)
            if face is not None:
                found.append(SlotFace(p, *face))
            if follow is not None and key >= 0:
                tracked[key] = follow
        self._tracked = tracked  # only faces of this sample are followed into the next
        self.rows.append(index)
        self.faces.append(found)
        self.seconds += time.perf_counter() - start

    def _mesh(self, image: np.ndarray, roi: Roi) -> FaceMesh:
        self._model = self._model or FaceLandmarker()
        self.passes += 1
        return self._model(image, roi)

    def _one(
        self, image: np.ndarray, kp: np.ndarray, key: int, *, alone: bool
    ) -> tuple[
        tuple[float, np.ndarray, np.ndarray, float] | None, tuple[np.ndarray, np.ndarray] | None
    ]:
        """((opening, axes, centre, residual) or None, (the mesh points, the body's nose) to
        follow it by) of one face."""
        work = self.work
        roi, why = face_box(keypoints=kp, skeleton=self.skeleton, config=work.speech)
        mouth = roi is not None and work.mouths and (work.mouth_alone or not alone)
        if roi is None and why != "face unseen" and work.head_limits is not None:
            turn, px = work.head_limits
            roi, _ = head_box(
                keypoints=kp,
                skeleton=self.skeleton,
                min_confidence=work.speech.min_face_confidence,
                max_turn=turn,
                min_px=px,
            )
        if roi is None or not (mouth or work.head_limits is not None):
            return None, None
        unseen = key >= 0 and not mouth and key not in self._seen
        misses = self._misses.get(key, 0) if unseen else 0
        if misses >= MISSES_BEFORE_BACKING_OFF:
            self._misses[key] = misses + 1
            if (misses - MISSES_BEFORE_BACKING_OFF) % RETRY_EVERY != RETRY_EVERY - 1:
                return None, None  # not looked for: as a head not found
        opening = np.nan
        if work.head_limits is None:  # the mouth alone: one pass on the body's crop
            alone_mesh = self._mesh(image, roi)
            if alone_mesh.presence >= MIN_FACE_PRESENCE:
                opening = alone_mesh.opening
            return (opening, _NO_AXES, _NO_CENTRE, np.nan), None
        previous = None if mouth else self._tracked.get(key)
        nose = np.array([roi.cx, roi.cy])
        mesh: FaceMesh | None = None
        if previous is not None:
            # the last mesh's crop, moved as the body's nose moved since (the head's own motion
            # between samples: 1 / mouth_rate_hz)
            last = mesh_roi(previous[0])
            shift = nose - previous[1]
            follow = Roi(last.cx + shift[0], last.cy + shift[1], last.side, last.angle)
            if _inside(follow, (roi.cx, roi.cy)):  # roi is centred on the body's nose
                mesh = self._mesh(image, follow)
                if mesh.presence < FOLLOW_PRESENCE:
                    mesh = None  # lost: found afresh below
        if mesh is None:
            first = self._mesh(image, roi)
            if mouth and first.presence >= MIN_FACE_PRESENCE:
                opening = first.opening
            mesh = self._mesh(image, mesh_roi(first.points))  # again, on the crop the mesh gives
            if mesh.presence < MIN_HEAD_PRESENCE:
                if unseen:
                    self._misses[key] = max(misses + 1, self._misses.get(key, 0))
                return (opening, _NO_AXES, _NO_CENTRE, np.nan), None
        self._misses.pop(key, None)
        self._seen.add(key)
        fit = fit_head(mesh.points3d)
        follow_next = (mesh.points, nose) if mesh.presence >= FOLLOW_PRESENCE else None
        return (opening, fit.axes, fit.centre, fit.residual), follow_next
