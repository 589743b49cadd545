"""Multi-person BlazePose on the TFLite runtime, tracked (detector `blazepose`).

The two models mediapipe 0.10.14 bundles (`pose_detection.tflite`, `pose_landmark_full.tflite`)
run in ai-edge-litert; the pre- and post-processing follow mediapipe's legacy pose graphs
(`modules/pose_detection/pose_detection_cpu.pbtxt`, `modules/pose_landmark/*.pbtxt`), for every
person instead of the first. Each tracked person's next region of interest (ROI) comes from
their own landmarks; the person detector runs every `detect_every_s` seconds of video time (to
find people who come in), at once when a track is lost, and on every frame while nobody is
tracked. It looks at the whole frame and, for elongated frames, at square tiles too (a second
person scores low beside a dominant one). A detection whose landmarks fall on a tracked person
is that person; when two tracks fall on one person, the one that moved is run again with that
person hidden. Landmarks are one-euro smoothed per track on the frames' own timestamps.

The package follows one frame through the models: `preprocess` (the views, crops and tensors the
models see), `inference` (the TFLite models), `postprocess` (their outputs decoded into boxes and
landmarks in image pixels), `tracker` (who is who from frame to frame, and the smoothing) and
`detector` (`BlazePoseDetector`, all of them over a video). Their public names are re-exported
here."""

from __future__ import annotations

from gesturebank.extract.detectors.blazepose.detector import BlazePoseDetector, most_seen
from gesturebank.extract.detectors.blazepose.inference import (
    DETECTOR_MODEL,
    LANDMARK_MODEL,
    RUNTIME_INSTALL,
    TfliteModel,
    load_interpreter,
    model_paths,
)
from gesturebank.extract.detectors.blazepose.postprocess import (
    HEATMAP_KERNEL,
    HEATMAP_MIN_CONFIDENCE,
    N_LANDMARKS,
    N_POINTS,
    NMS_IOU,
    Landmarks,
    PersonBoxes,
    box_iou,
    decode_detections,
    decode_landmarks,
    refine_from_heatmap,
    sigmoid,
    ssd_anchors,
    to_pixels,
    weighted_nms,
)
from gesturebank.extract.detectors.blazepose.preprocess import (
    DETECTOR_SIZE,
    HIDE_GREY,
    LANDMARK_SIZE,
    ROI_SCALE,
    TILE_ASPECT,
    Disc,
    Roi,
    detection_views,
    detector_input,
    landmark_input,
    roi_from_points,
    square_transform,
    warp,
)
from gesturebank.extract.detectors.blazepose.tracker import (
    AUX,
    AUX_BETA,
    AUX_MIN_CUTOFF,
    FACE,
    FACE_RADIUS,
    HIDDEN_APART,
    LEGS,
    MIN_SMALL_PERSON,
    SAME_PERSON_DISTANCE,
    TORSO,
    TORSO_RADIUS,
    TORSOS_APART,
    WAIST_UP,
    Tracker,
    inside,
    on_legs,
    person_discs,
    person_size,
    same_person,
    torso_distance,
    torsos_apart,
)

__all__ = [
    "AUX",
    "AUX_BETA",
    "AUX_MIN_CUTOFF",
    "DETECTOR_MODEL",
    "DETECTOR_SIZE",
    "FACE",
    "FACE_RADIUS",
    "HEATMAP_KERNEL",
    "HEATMAP_MIN_CONFIDENCE",
    "HIDDEN_APART",
    "HIDE_GREY",
    "LANDMARK_MODEL",
    "LANDMARK_SIZE",
    "LEGS",
    "MIN_SMALL_PERSON",
    "NMS_IOU",
    "N_LANDMARKS",
    "N_POINTS",
    "ROI_SCALE",
    "RUNTIME_INSTALL",
    "SAME_PERSON_DISTANCE",
    "TILE_ASPECT",
    "TORSO",
    "TORSOS_APART",
    "TORSO_RADIUS",
    "WAIST_UP",
    "BlazePoseDetector",
    "Disc",
    "Landmarks",
    "PersonBoxes",
    "Roi",
    "TfliteModel",
    "Tracker",
    "box_iou",
    "decode_detections",
    "decode_landmarks",
    "detection_views",
    "detector_input",
    "inside",
    "landmark_input",
    "load_interpreter",
    "model_paths",
    "most_seen",
    "on_legs",
    "person_discs",
    "person_size",
    "refine_from_heatmap",
    "roi_from_points",
    "same_person",
    "sigmoid",
    "square_transform",
    "ssd_anchors",
    "to_pixels",
    "torso_distance",
    "torsos_apart",
    "warp",
    "weighted_nms",
]
