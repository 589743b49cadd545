"""`BlazePoseDetector`: the person detector and the landmark model over a video, everybody tracked
(detector `blazepose`); `most_seen` picks the person seen the most."""

from __future__ import annotations

import os
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from gesturebank.config import BlazePoseConfig
from gesturebank.errors import DetectionError
from gesturebank.extract.detectors import Frame, PeopleHook
from gesturebank.extract.detectors.blazepose.inference import TfliteModel, model_paths
from gesturebank.extract.detectors.blazepose.postprocess import (
    NMS_IOU,
    Landmarks,
    PersonBoxes,
    box_iou,
    decode_detections,
    decode_landmarks,
    ssd_anchors,
    to_pixels,
    weighted_nms,
)
from gesturebank.extract.detectors.blazepose.preprocess import (
    DETECTOR_SIZE,
    Disc,
    Roi,
    detection_views,
    detector_input,
    landmark_input,
    roi_from_points,
)
from gesturebank.extract.detectors.blazepose.tracker import Tracker
from gesturebank.poses import MultiPose2D, Pose2D
from gesturebank.skeletons import BLAZEPOSE33


class BlazePoseDetector:
    """BlazePose Full for several people at once, tracked; `detect_people` for everybody,
    `detect` for the person seen the most."""

    name = "blazepose"
    version = 3  # in the detection cache key: bump when a video gives other output (3: hiding)
    skeleton = BLAZEPOSE33.name

    def __init__(
        self,
        config: BlazePoseConfig | None = None,
        *,
        video: object = None,
        threads: int | None = None,
    ) -> None:
        self.config = config or BlazePoseConfig()
        self.threads = threads or os.cpu_count() or 1
        detector_path, landmark_path = model_paths()
        self._detector = TfliteModel(detector_path, self.threads)
        self._landmarks = TfliteModel(landmark_path, self.threads)
        self._anchors = ssd_anchors()

    # -- one model pass each

    def find_people(self, image: np.ndarray) -> PersonBoxes:
        """Everybody the person detector sees in an RGB uint8 `(H, W, 3)` image: each view's
        detections (weighted NMS), whole frame first; a tile's detection whose face box
        overlaps an earlier one's is the same person and dropped."""
        width, height = image.shape[1::-1]
        views = detection_views(width, height, small=self.config.small_people)
        found = [self._find_in_view(image, v) for v in views]
        boxes = np.concatenate([f.boxes for f in found])
        keep: list[int] = []
        for i in range(len(boxes)):
            if not keep or np.all(box_iou(boxes[i], boxes[keep]) <= NMS_IOU):
                keep.append(i)
        coarse = len(detection_views(width, height))
        small = np.concatenate([np.full(len(f), v >= coarse) for v, f in enumerate(found)])
        return PersonBoxes(
            boxes[keep],
            np.concatenate([f.keypoints for f in found])[keep],
            np.concatenate([f.scores for f in found])[keep],
            small[keep],
        )

    def _find_in_view(self, image: np.ndarray, to_image: np.ndarray) -> PersonBoxes:
        out = self._detector(detector_input(image, to_image))
        boxes, kps, scores = decode_detections(
            out["Identity"],
            out["Identity_1"],
            anchors=self._anchors,
            min_score=self.config.min_detection_confidence,
        )
        boxes, kps, scores = weighted_nms(boxes, kps, scores=scores)
        corners = to_pixels(boxes.reshape(-1, 2, 2), to_image, size=DETECTOR_SIZE).reshape(-1, 4)
        return PersonBoxes(
            corners,
            to_pixels(kps, to_image, size=DETECTOR_SIZE),
            scores,
            np.zeros(len(scores), bool),
        )

    def landmarks(self, image: np.ndarray, roi: Roi, hide: Iterable[Disc] = ()) -> Landmarks:
        """One landmark pass on `roi` of an RGB uint8 image, the discs `hide` painted over."""
        return decode_landmarks(self._landmarks(landmark_input(image, roi, hide=hide)), roi)

    # -- video

    def detect_people(
        self, frames: Iterable[Frame], on_people: PeopleHook | None = None
    ) -> MultiPose2D:
        """Everybody, tracked: keypoints (T, P, 33, 3) x px, y px, visibility; world (T, P, 33, 3)
        metres; ids (T, P) track ids (-1 = empty slot); NaN where a slot is empty.
        on_people(index, t, image, keypoints (P, 33, 3), ids (P,)): each frame's people as
        they are found, with the frame (the face pass, `extract.face_pass`, runs there instead
        of decoding the video again)."""
        times: list[float] = []
        people: list[np.ndarray] = []
        worlds: list[np.ndarray] = []
        ids: list[np.ndarray] = []
        size: tuple[int, int] | None = None
        # the person detector's searches beside the tracks' landmark passes (`Tracker`)
        with ThreadPoolExecutor(1, thread_name_prefix="people") as beside:
            tracker = Tracker(self, beside)
            for t, image in frames:
                size = size or (image.shape[1], image.shape[0])
                kp, wd, tid = tracker.step(float(t), image)
                if on_people is not None:
                    on_people(len(times), float(t), image, kp, tid)
                times.append(float(t))
                people.append(kp)
                worlds.append(wd)
                ids.append(tid)
        if size is None:
            raise DetectionError("blazepose: no frames to detect on")
        return MultiPose2D.from_people(people, np.asarray(times), self.skeleton, size, worlds, ids)

    def detect(self, frames: Iterable[Frame]) -> Pose2D:
        """(T, 33, 3) keypoints of the track seen in the most frames (NaN where it is not)."""
        return most_seen(self.detect_people(frames))

    def detect_each_frame(self, frames: Iterable[Frame]) -> Pose2D:
        """(T, 33, 3) keypoints of the strongest person in each frame, every frame on its own:
        the person detector, the ROI from its detection, one landmark pass, nothing carried
        from the frame before (no ROI tracking, no smoothing). The yardstick the tracked
        output is held to (issue 39: on fast motion the tracked 2D must be as good); twice
        the model passes of `detect`."""
        times: list[float] = []
        points: list[np.ndarray] = []
        worlds: list[np.ndarray] = []
        size: tuple[int, int] | None = None
        k = len(BLAZEPOSE33)
        for t, image in frames:
            size = size or (image.shape[1], image.shape[0])
            kp, world = np.full((k, 3), np.nan), np.full((k, 3), np.nan)
            dets = self.find_people(image)
            if len(dets):
                best = int(np.argmax(dets.scores))
                lm = self.landmarks(
                    image, roi_from_points(dets.keypoints[best, 0], dets.keypoints[best, 1])
                )
                if lm.presence >= self.config.min_tracking_confidence:
                    kp = np.hstack([lm.points[:k, :2], np.clip(lm.points[:k, 2:3], 0.0, 1.0)])
                    world = lm.world
            times.append(float(t))
            points.append(kp)
            worlds.append(world)
        if size is None:
            raise DetectionError("blazepose: no frames to detect on")
        return Pose2D(
            np.stack(points).astype(np.float32),
            np.asarray(times),
            self.skeleton,
            size,
            np.stack(worlds).astype(np.float32),
        )


def most_seen(multi: MultiPose2D) -> Pose2D:
    """The track with the most frames of `multi` as a Pose2D (slot 0 when it has no ids)."""
    if multi.ids is None:
        return multi.slot(0)
    tracked = multi.ids[multi.ids >= 0]
    kp = np.full(multi.keypoints.shape[:1] + multi.keypoints.shape[2:], np.nan, np.float32)
    world = None if multi.world is None else np.full_like(kp, np.nan)
    if len(tracked):
        best = np.bincount(tracked).argmax()
        t, p = np.nonzero(multi.ids == best)
        kp[t] = multi.keypoints[t, p]
        if world is not None and multi.world is not None:
            world[t] = multi.world[t, p]
    return Pose2D(kp, multi.timestamps, multi.skeleton, multi.image_size, world)
