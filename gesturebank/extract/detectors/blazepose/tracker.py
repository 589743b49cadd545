"""BlazePose tracking: who is who from frame to frame (`Tracker`, the state of
`BlazePoseDetector.detect_people`).

Each tracked person's next ROI comes from their own landmarks, one-euro smoothed on the frames'
own timestamps. A detection whose landmarks fall on a tracked person is that person; when two
tracks fall on one person, the one that moved is run again with that person hidden."""

from __future__ import annotations

from collections.abc import Iterable
from concurrent.futures import Executor, Future, wait
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import numpy as np

from gesturebank.extract.detectors.blazepose.postprocess import (
    N_LANDMARKS,
    Landmarks,
    PersonBoxes,
)
from gesturebank.extract.detectors.blazepose.preprocess import Disc, Roi, roi_from_points
from gesturebank.filters import OneEuro
from gesturebank.skeletons import BLAZEPOSE33

if TYPE_CHECKING:
    from gesturebank.config import BlazePoseConfig


class PoseModels(Protocol):
    """What the tracker runs (`BlazePoseDetector`): its settings and its two model passes."""

    config: BlazePoseConfig

    def find_people(self, image: np.ndarray) -> PersonBoxes: ...

    def landmarks(self, image: np.ndarray, roi: Roi, hide: Iterable[Disc] = ()) -> Landmarks: ...


WAIST_UP = slice(0, 25)  # nose to hips: what a waist-up shot shows
LEGS = slice(23, 33)  # hips to feet
AUX = (33, 34)  # tensors_to_pose_landmarks_and_segmentation: ranges { begin: 33 end: 35 }
# pose_landmark_filtering: auxiliary points are smoothed harder, so the crop stays still.
AUX_MIN_CUTOFF, AUX_BETA = 0.01, 10.0
# Two poses are one person when their upper-body landmarks (0-24) lie closer than this fraction
# of the person's size (median distance). Measured between detections and tracks on the Pose2Sim
# demos and Sports2D: one person seen twice 0.00-0.12 (two fits of a fast lunge or of a person
# whose crop holds a second one), two people 0.21 and more. ROI overlap cannot tell: the ROIs
# of two people standing side by side overlap by IoU 0.59 (Demo_MultiPerson cam03).
SAME_PERSON_DISTANCE = 0.15
# Two tracks whose torsos (shoulders, hips) lie farther apart than this (median, same units)
# are two people even when their upper bodies count as one: a man leaning across a woman gets
# his face fitted onto hers (Demo_MultiPerson cam03 at 0.9-1.4 s: upper bodies 0.07-0.18,
# torsos 0.21-0.32). Pairs that are one person (cam03, cam04, 60 fps): torsos 0.00-0.08.
TORSO = [11, 12, 23, 24]  # shoulders, hips
TORSOS_APART = 0.2
# When two tracks fall on one person, the one whose torso moved more is run again with that
# person hidden: mid-grey discs over their face (landmarks 0-10, FACE_RADIUS of their size) and
# along their torso (shoulders, waist, hips; TORSO_RADIUS of their shoulder width). The landmark
# model fits the one face in its crop, and a person seen from behind has none: Demo_MultiPerson
# cam03 from 1.37 s: the man, back to the camera, overlapping the woman, came out with her face
# and then her body. With her face hidden his hips stay 24-135 px right of hers, with her torso
# hidden too 46-139 px (by eye 100-125 px at 1.5-1.63 s: the side of him next to her drifts).
FACE = slice(0, 11)  # nose, eyes, ears, mouth
FACE_RADIUS = 0.09
TORSO_RADIUS = 0.5
# A landmark set found with a person hidden is somebody else when its torso lies this far from
# theirs (TORSO units; one person twice: 0.00-0.08). The man above: 0.15-0.22 from the woman.
HIDDEN_APART = 0.1
# A person found only in a square of half the short side (`small_people`) is kept when their
# size (`person_size`) is at least this share of the frame's short side. Bigger people are found
# in the coarser views; a smaller pose in a small square is fitted to an object or to a part of
# somebody. Demo_MultiPerson: the far bystander 0.37-0.41 (cam01, cam02); a pose fitted to a
# wall camera's mount 0.19 (cam03) and to the man's cap and shoulders 0.28 (cam04).
MIN_SMALL_PERSON = 0.3


def person_size(points: np.ndarray) -> float:
    """Size of the person in pixels: the side of the unscaled ROI, 2·|aux1 − aux0|."""
    return 2.0 * float(np.linalg.norm(points[AUX[1], :2] - points[AUX[0], :2]))


def _distance(a: np.ndarray, b: np.ndarray) -> float:
    """Median distance of the upper-body landmarks of two sets `(39, ≥2)` px, in units of the
    smaller person's size."""
    d = np.linalg.norm(a[WAIST_UP, :2] - b[WAIST_UP, :2], axis=1)
    return float(np.median(d)) / max(min(person_size(a), person_size(b)), 1.0)


def same_person(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two landmark sets `(39, ≥2)` px are one person (SAME_PERSON_DISTANCE)."""
    return _distance(a, b) < SAME_PERSON_DISTANCE


def torso_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Median distance of the shoulders and hips of two landmark sets `(39, ≥2)` px, in units of
    the smaller person's size."""
    d = np.linalg.norm(a[TORSO, :2] - b[TORSO, :2], axis=1)
    return float(np.median(d)) / max(min(person_size(a), person_size(b)), 1.0)


def torsos_apart(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether the torsos of two landmark sets `(39, ≥2)` px are two people's (TORSOS_APART)."""
    return torso_distance(a, b) > TORSOS_APART


def _duplicate(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two tracks' landmark sets `(39, ≥2)` px are one person: upper bodies together and
    torsos not apart."""
    return same_person(a, b) and not torsos_apart(a, b)


def _jumped(before: np.ndarray, after: np.ndarray) -> bool:
    """Whether a track's landmarks moved from one frame to the next as far as two people are
    apart."""
    return not same_person(before, after)


def on_legs(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether pose `a (39, ≥2)` px is a phantom made of `b`'s legs: most of its upper body lies
    in the box of b's hips-to-feet landmarks. The detector, shown a tile that holds only
    someone's legs, finds a person in them (Demo_SinglePerson cam02: score 0.65, presence 0.97).
    """
    return _mostly_in_box(a, b[LEGS])


def inside(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether most of pose `a (39, ≥2)`'s upper body lies in the box of all of `b`'s landmarks:
    a part of `b` taken for a person of its own. A square of half the frame's short side that
    holds someone's head and shoulders gets a second, smaller pose fitted to them
    (Demo_MultiPerson cam04, `small_people`: the man's head, 18 % of frames)."""
    return _mostly_in_box(a, b[:N_LANDMARKS])


def _mostly_in_box(a: np.ndarray, points: np.ndarray) -> bool:
    """Whether most of `a (39, ≥2)`'s upper-body landmarks lie in the box of `points (K, ≥2)`."""
    lo, hi = points[:, :2].min(axis=0), points[:, :2].max(axis=0)
    upper = a[WAIST_UP, :2]
    return bool(np.mean(np.all((upper >= lo) & (upper <= hi), axis=1)) > 0.5)


def person_discs(points: np.ndarray) -> list[Disc]:
    """Discs that hide the face and torso of landmark set `points (39, ≥2)` px (FACE_RADIUS,
    TORSO_RADIUS)."""
    face = points[FACE, :2].mean(axis=0)
    shoulders, hips = points[[11, 12], :2].mean(axis=0), points[[23, 24], :2].mean(axis=0)
    radius = TORSO_RADIUS * float(np.linalg.norm(points[11, :2] - points[12, :2]))
    torso = [(p, radius) for p in (shoulders, (shoulders + hips) / 2, hips)]
    return [
        ((float(c[0]), float(c[1])), r)
        for c, r in [(face, FACE_RADIUS * person_size(points)), *torso]
    ]


@dataclass
class _Track:
    """One followed person: the ROI for the next frame, their last raw landmarks (39, 4) px, and
    their smoothing filters."""

    id: int
    roi: Roi
    points: np.ndarray
    image: OneEuro | None = None
    world: OneEuro | None = None
    aux: OneEuro = field(default_factory=lambda: OneEuro(min_cutoff=AUX_MIN_CUTOFF, beta=AUX_BETA))


def _smoothed(track: _Track, lm: Landmarks, t: float) -> tuple[np.ndarray, np.ndarray, Roi]:
    """((33, 3) x px, y px, confidence; (33, 3) world; next ROI) of a track, smoothed as
    pose_landmark_filtering does: image speeds divided by the person's size in pixels (the
    side of the unscaled ROI from the raw auxiliary points), world landmarks unscaled."""
    size = person_size(lm.points)
    xy = lm.points[:N_LANDMARKS, :2]
    world = lm.world
    if track.image is not None and track.world is not None and size > 1e-6:
        xy = track.image.step(xy, t, scale=1.0 / size)
        world = track.world.step(world, t)
    aux = track.aux.step(lm.points[list(AUX), :2], t, scale=1.0 / max(size, 1e-6))
    conf = np.clip(lm.points[:N_LANDMARKS, 2:3], 0.0, 1.0)
    return np.hstack([xy, conf]), world, roi_from_points(aux[0], aux[1])


class Tracker:
    """Frame-by-frame state of `detect_people`: the live tracks and the detector's clock.

    `beside`: a thread that runs the person detector while this one runs the tracks' landmark
    passes, on the frames where the search is due on the clock (the landmarks cannot change
    that it runs there, nor what it finds: it sees the frame alone), so one worker keeps both
    cores busy (issue 43). None: one after the other."""

    def __init__(self, detector: PoseModels, beside: Executor | None = None) -> None:
        self.det = detector
        self.cfg = detector.config
        self.tracks: list[_Track] = []
        self.next_id = 0
        self.last_detection: float | None = None
        self.beside = beside

    def step(self, t: float, image: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """((N, 33, 3) keypoints, (N, 33, 3) world, (N,) ids) of the people in this frame."""
        found: list[tuple[_Track, Landmarks]] = []
        lost = False
        # due on the clock with room for somebody: `_new_people` will search this frame
        search = None
        if self.beside is not None and self.tracks and len(self.tracks) < self.cfg.max_people:
            if self._detection_due(t):
                search = self.beside.submit(self.det.find_people, image)
        try:
            for track in self.tracks:
                lm = self.det.landmarks(image, track.roi)
                if lm.presence >= self.cfg.min_tracking_confidence:
                    found.append((track, lm))
                else:
                    lost = True
            found = self._unique(image, found)
        except BaseException:
            if search is not None:
                wait([search])  # not left running on the way out
            raise
        if lost or not found or self._detection_due(t):
            found += self._new_people(t, image, found, search)
        return self._emit(t, found)

    def _detection_due(self, t: float) -> bool:
        return self.last_detection is None or t - self.last_detection >= (
            self.cfg.detect_every_s - 1e-6
        )

    def _unique(
        self, image: np.ndarray, found: list[tuple[_Track, Landmarks]]
    ) -> list[tuple[_Track, Landmarks]]:
        """When two tracks now follow one person, the one that jumped or whose torso moved more
        is run again with that person hidden (person_discs): the landmark model drifts to the
        more upright of two overlapping people, the one with a face. If that finds somebody else,
        the two landmark sets go to the two tracks by torso distance to their last landmarks;
        if not, the track is dropped. Tracks whose torsos stay apart are kept both: only a part
        of one (the face) moved onto the other. (A new detection must be apart as a whole.)"""
        kept: list[tuple[_Track, Landmarks]] = []
        order = sorted(
            found,
            key=lambda f: (
                _jumped(f[0].points, f[1].points),
                torso_distance(f[0].points, f[1].points),
                f[0].id,
            ),
        )
        for track, lm in order:
            i = next((i for i, (_, k) in enumerate(kept) if _duplicate(lm.points, k.points)), None)
            if i is None:
                kept.append((track, lm))
                continue
            other, seen = kept[i]
            again = self.det.landmarks(image, track.roi, hide=person_discs(seen.points))
            if again.presence < self.cfg.min_tracking_confidence or any(
                torso_distance(again.points, k.points) < HIDDEN_APART for _, k in kept
            ):
                continue
            stay = torso_distance(seen.points, other.points) + torso_distance(
                again.points, track.points
            )
            swap = torso_distance(seen.points, track.points) + torso_distance(
                again.points, other.points
            )
            kept[i] = (other, again if swap < stay else seen)
            kept.append((track, seen if swap < stay else again))
        return kept

    def _new_people(
        self,
        t: float,
        image: np.ndarray,
        found: list[tuple[_Track, Landmarks]],
        search: Future[PersonBoxes] | None = None,
    ) -> list[tuple[_Track, Landmarks]]:
        """Tracks for detected people not already followed, strongest first, up to max_people
        (`search`: the person detector on this frame, run beside)."""
        self.last_detection = t
        if len(found) >= self.cfg.max_people:
            return []
        dets = self.det.find_people(image) if search is None else search.result()
        taken = [lm.points for _, lm in found]
        new: list[tuple[_Track, Landmarks]] = []
        for i in range(len(dets)):
            if len(found) + len(new) >= self.cfg.max_people:
                break
            roi = roi_from_points(dets.keypoints[i, 0], dets.keypoints[i, 1])
            lm = self.det.landmarks(image, roi)
            if lm.presence < self.cfg.min_tracking_confidence or any(
                same_person(lm.points, other) or on_legs(lm.points, other) for other in taken
            ):
                continue
            if dets.small[i] and (
                person_size(lm.points) < MIN_SMALL_PERSON * min(image.shape[:2])
                or any(inside(lm.points, other) for other in taken)
            ):
                continue
            taken.append(lm.points)
            new.append((self._new_track(roi, lm), lm))
        return new

    def _new_track(self, roi: Roi, lm: Landmarks) -> _Track:
        track = _Track(self.next_id, roi, lm.points)
        if self.cfg.smoothing:
            track.image = OneEuro(
                min_cutoff=self.cfg.smoothing_min_cutoff, beta=self.cfg.smoothing_beta
            )
            track.world = OneEuro(
                min_cutoff=self.cfg.world_smoothing_min_cutoff,
                beta=self.cfg.world_smoothing_beta,
            )
        self.next_id += 1
        return track

    def _emit(
        self, t: float, found: list[tuple[_Track, Landmarks]]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        kps, worlds, ids = [], [], []
        found = sorted(found, key=lambda f: f[0].id)
        for track, lm in found:
            kp, world, track.roi = _smoothed(track, lm, t)
            track.points = lm.points
            kps.append(kp)
            worlds.append(world)
            ids.append(track.id)
        self.tracks = [track for track, _ in found]
        k = len(BLAZEPOSE33)
        if not kps:
            empty = np.zeros((0, k, 3), np.float32)
            return empty, empty, np.zeros(0, np.int64)
        return (
            np.stack(kps).astype(np.float32),
            np.stack(worlds).astype(np.float32),
            np.array(ids, np.int64),
        )
