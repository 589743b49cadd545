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

Geometry in pixels: an ROI is a rotated square (centre, side, angle); a crop maps tensor pixel
(u, v) to image point c + side · R(angle) · ((u, v) / n − ½)."""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from gesturebank.config import DetectorConfig
from gesturebank.errors import DetectionError
from gesturebank.extract.detectors import Frame
from gesturebank.extract.detectors.mediapipe import INSTALL, _quiet_startup
from gesturebank.filters import OneEuro
from gesturebank.poses import MultiPose2D, Pose2D
from gesturebank.skeletons import BLAZEPOSE33

RUNTIME_INSTALL = "pip install ai-edge-litert==2.3.0"
DETECTOR_MODEL = Path("modules") / "pose_detection" / "pose_detection.tflite"
LANDMARK_MODEL = Path("modules") / "pose_landmark" / "pose_landmark_full.tflite"

DETECTOR_SIZE = 224  # pose_detection_cpu: ImageToTensor output_tensor_width/height
LANDMARK_SIZE = 256  # pose_landmark_by_roi_cpu: ImageToTensor output_tensor_width/height
N_POINTS = 39  # 33 landmarks + 2 auxiliary (ROI) points + 4 unused
N_LANDMARKS = 33
WAIST_UP = slice(0, 25)  # nose to hips: what a waist-up shot shows
LEGS = slice(23, 33)  # hips to feet
AUX = (33, 34)  # tensors_to_pose_landmarks_and_segmentation: ranges { begin: 33 end: 35 }
ROI_SCALE = 1.25  # pose_detection_to_roi / pose_landmarks_to_roi: scale_x, scale_y
NMS_IOU = 0.3  # pose_detection_cpu: NonMaxSuppression min_suppression_threshold (WEIGHTED)
HEATMAP_KERNEL = 7  # RefineLandmarksFromHeatmap kernel_size
HEATMAP_MIN_CONFIDENCE = 0.5  # its min_confidence_to_refine (proto default)
# pose_landmark_filtering: auxiliary points are smoothed harder, so the crop stays still.
AUX_MIN_CUTOFF, AUX_BETA = 0.01, 10.0
# Frames this much longer than wide are also searched in square tiles (see detection_views).
TILE_ASPECT = 1.2
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
HIDE_GREY = (127.5, 127.5, 127.5)
# A landmark set found with a person hidden is somebody else when its torso lies this far from
# theirs (TORSO units; one person twice: 0.00-0.08). The man above: 0.15-0.22 from the woman.
HIDDEN_APART = 0.1
# A person found only in a square of half the short side (`small_people`) is kept when their
# size (`person_size`) is at least this share of the frame's short side. Bigger people are found
# in the coarser views; a smaller pose in a small square is fitted to an object or to a part of
# somebody. Demo_MultiPerson: the far bystander 0.37-0.41 (cam01, cam02); a pose fitted to a
# wall camera's mount 0.19 (cam03) and to the man's cap and shoulders 0.28 (cam04).
MIN_SMALL_PERSON = 0.3
Disc = tuple[tuple[float, float], float]  # centre (x, y) px, radius px


def sigmoid(x: np.ndarray) -> np.ndarray:
    """Logistic function in float64 (float32 overflows exp at the ±100 clip)."""
    return 1.0 / (1.0 + np.exp(-np.asarray(x, np.float64)))


# ---------------------------------------------------------------- models and runtime


def model_paths() -> tuple[Path, Path]:
    """(detector, landmark) .tflite files of the installed mediapipe wheel; DetectionError with
    the install command when either is missing. mediapipe itself is never imported."""
    spec = importlib.util.find_spec("mediapipe")
    if spec is None or not spec.submodule_search_locations:
        raise DetectionError(f"detector 'blazepose' needs the mediapipe wheel's models: {INSTALL}")
    root = Path(next(iter(spec.submodule_search_locations)))
    for model in (DETECTOR_MODEL, LANDMARK_MODEL):
        if not (root / model).is_file():
            raise DetectionError(
                f"{root / model}: BlazePose model missing from the installed mediapipe "
                f"(releases after 0.10.21 dropped it): {INSTALL}"
            )
    return root / DETECTOR_MODEL, root / LANDMARK_MODEL


def load_interpreter(path: Path, threads: int) -> Any:
    """An allocated ai-edge-litert Interpreter for `path`; DetectionError if the runtime is
    missing."""
    if importlib.util.find_spec("ai_edge_litert") is None:
        raise DetectionError(f"detector 'blazepose' needs the TFLite runtime: {RUNTIME_INSTALL}")
    from ai_edge_litert.interpreter import Interpreter

    with _quiet_startup():  # the XNNPACK delegate announces itself on fd 2
        interpreter = Interpreter(model_path=str(path), num_threads=threads)
        interpreter.allocate_tensors()
    return interpreter


class _Model:
    """One interpreter with its input and named outputs."""

    def __init__(self, path: Path, threads: int) -> None:
        self.interpreter = load_interpreter(path, threads)
        self.input = self.interpreter.get_input_details()[0]["index"]
        self.outputs = {d["name"]: d["index"] for d in self.interpreter.get_output_details()}

    def __call__(self, tensor: np.ndarray) -> dict[str, np.ndarray]:
        """(1, n, n, 3) float32 in → every output by name, batch dimension dropped."""
        self.interpreter.set_tensor(self.input, tensor)
        self.interpreter.invoke()
        return {k: self.interpreter.get_tensor(i)[0] for k, i in self.outputs.items()}


# ---------------------------------------------------------------- person detector


def ssd_anchors(
    *,
    input_size: int = DETECTOR_SIZE,
    strides: tuple[int, ...] = (8, 16, 32, 32, 32),
    anchors_per_layer: int = 2,
    offset: float = 0.5,
) -> np.ndarray:
    """(N, 2) anchor centres x, y in [0, 1] of pose_detection_cpu's SsdAnchorsCalculator.

    Consecutive layers with one stride share a grid, cell-major, each layer adding its anchors
    per cell: one per aspect ratio (1.0) plus the interpolated-scale one. With
    fixed_anchor_size every anchor is 1 × 1, so min_scale / max_scale (0.1484375 / 0.75) do not
    change the decoding and only the centres are needed: 28² · 2 + 14² · 2 + 7² · 6 = 2254.
    """
    out = []
    i = 0
    while i < len(strides):
        same = sum(1 for s in strides[i:] if s == strides[i])
        cells = int(np.ceil(input_size / strides[i]))
        centre = (np.arange(cells) + offset) / cells
        yy, xx = np.meshgrid(centre, centre, indexing="ij")
        grid = np.stack([xx.ravel(), yy.ravel()], axis=-1)
        out.append(np.repeat(grid, same * anchors_per_layer, axis=0))
        i += same
    return np.concatenate(out)


@dataclass(frozen=True)
class Detections:
    """People found by the detector, strongest first, in image pixels.

    boxes: (N, 4) x0, y0, x1, y1 of the face box; keypoints: (N, 4, 2) mid-hip, full-body
    size/rotation point, mid-shoulder, upper-body point; scores: (N,) in [0, 1]; small: (N,)
    found only in a square of half the short side (`detection_views(small=True)`).
    """

    boxes: np.ndarray
    keypoints: np.ndarray
    scores: np.ndarray
    small: np.ndarray

    def __len__(self) -> int:
        return len(self.scores)


def square_transform(x0: float, y0: float, side: float, size: int = DETECTOR_SIZE) -> np.ndarray:
    """(2, 3) affine map of `size` tensor pixels onto the image square at (x0, y0) of `side` px."""
    s = side / size
    return np.array([[s, 0.0, x0], [0.0, s, y0]])


def detection_views(width: int, height: int, *, small: bool = False) -> list[np.ndarray]:
    """(2, 3) tensor-to-image maps the person detector looks through, whole frame first.

    The whole frame is centred in a square of its long side (zero border), as ImageToTensor
    with keep_aspect_ratio does. The detector, trained on one dominant person, scores a second
    person low in that view (the woman behind the man in Pose2Sim Demo_MultiPerson cam03: 0.13
    whole, 0.94 in a square tile), so frames more than TILE_ASPECT times longer than wide add
    squares of the short side spaced evenly along the long side.

    `small` adds squares of half the short side, overlapping (one more than they need to
    cover each side), for people whose face is too small for the detector in the views above:
    the far bystander of Demo_MultiPerson cam01 is not found in the whole frame nor in squares
    of the short side, but at 0.77 in a square of half of it. Only where such a square is at
    least the detector's input (224 px): a smaller one is upsampled, adds no pixels and finds
    only phantoms (a 202×360 video: 22 short tracks of 20-57 px poses on the floor).
    """
    long, short = max(width, height), min(width, height)
    views = [square_transform((width - long) / 2, (height - long) / 2, long)]
    if long >= TILE_ASPECT * short:
        for start in np.linspace(0, long - short, int(np.ceil(long / short))):
            x0, y0 = (start, 0.0) if width > height else (0.0, start)
            views.append(square_transform(x0, y0, short))
    if small and short / 2 >= DETECTOR_SIZE:
        side = short / 2
        xs, ys = (np.linspace(0, n - side, int(np.ceil(n / side)) + 1) for n in (width, height))
        views += [square_transform(x0, y0, side) for y0 in ys for x0 in xs]
    return views


def warp(image: np.ndarray, to_image: np.ndarray, size: int, border: int) -> np.ndarray:
    """(size, size, 3) float32 sampled (bilinear) from `image` through `to_image` (2, 3)."""
    return cv2.warpAffine(
        image,
        to_image,
        (size, size),
        flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=border,
        borderValue=(0, 0, 0),
    ).astype(np.float32)


def detector_input(image: np.ndarray, to_image: np.ndarray) -> np.ndarray:
    """(1, 224, 224, 3) RGB in [−1, 1] of an RGB uint8 image seen through `to_image`."""
    return (warp(image, to_image, DETECTOR_SIZE, cv2.BORDER_CONSTANT) / 127.5 - 1.0)[None]


def decode_detections(
    raw: np.ndarray,
    logits: np.ndarray,
    anchors: np.ndarray,
    *,
    min_score: float,
    size: int = DETECTOR_SIZE,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Candidates above `min_score`: (boxes (M, 4) x0 y0 x1 y1, keypoints (M, 4, 2), scores (M,)),
    normalised to the detector tensor.

    raw: (N, 12) per anchor box centre x, y, w, h then 4 keypoints x, y (reverse_output_order:
    x before y), in tensor pixels relative to the anchor (x/y/w/h_scale 224); logits: (N,).
    Scores: logits clipped to ±100 (score_clipping_thresh) then sigmoid (sigmoid_score).
    """
    scores = sigmoid(np.clip(logits.reshape(-1).astype(np.float64), -100.0, 100.0))
    keep = scores >= min_score
    raw, a, scores = raw[keep] / size, anchors[keep], scores[keep]
    centre = raw[:, :2] + a
    half = raw[:, 2:4] / 2
    boxes = np.concatenate([centre - half, centre + half], axis=1)
    keypoints = raw[:, 4:12].reshape(-1, 4, 2) + a[:, None]
    return boxes, keypoints, scores


def box_iou(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """(M,) intersection over union of `box (4,)` with `boxes (M, 4)`, both x0 y0 x1 y1."""
    lo = np.maximum(box[:2], boxes[:, :2])
    hi = np.minimum(box[2:], boxes[:, 2:])
    inter = np.prod(np.clip(hi - lo, 0, None), axis=1)
    area = np.prod(box[2:] - box[:2]) + np.prod(boxes[:, 2:] - boxes[:, :2], axis=1)
    return inter / np.maximum(area - inter, 1e-12)


def weighted_nms(
    boxes: np.ndarray, keypoints: np.ndarray, scores: np.ndarray, *, iou: float = NMS_IOU
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weighted non-maximum suppression (NonMaxSuppression algorithm WEIGHTED): the strongest
    remaining candidate and all overlapping it by more than `iou` become one detection, their
    boxes and keypoints averaged with score weights, keeping the strongest score. Shapes as
    `decode_detections`, strongest first."""
    order = np.argsort(-scores, kind="stable")
    out_b, out_k, out_s = [], [], []
    while len(order):
        overlap = box_iou(boxes[order[0]], boxes[order]) > iou
        overlap[0] = True
        group, order = order[overlap], order[~overlap]
        w = scores[group][:, None]
        out_b.append((boxes[group] * w).sum(0) / w.sum())
        out_k.append((keypoints[group] * w[:, :, None]).sum(0) / w.sum())
        out_s.append(scores[group[0]])
    if not out_s:
        return np.zeros((0, 4)), np.zeros((0, 4, 2)), np.zeros(0)
    return np.array(out_b), np.array(out_k), np.array(out_s)


def to_pixels(points: np.ndarray, to_image: np.ndarray, size: int) -> np.ndarray:
    """(..., 2) points normalised to a `size` tensor → image pixels through `to_image` (2, 3);
    for the letterbox this is DetectionLetterboxRemoval followed by the image size."""
    p = np.asarray(points) * size
    return p @ to_image[:, :2].T + to_image[:, 2]


# ---------------------------------------------------------------- regions of interest


@dataclass(frozen=True)
class Roi:
    """A rotated square in image pixels: centre (cx, cy), side, angle (radians, image axes)."""

    cx: float
    cy: float
    side: float
    angle: float

    def crop_transform(self, size: int = LANDMARK_SIZE) -> np.ndarray:
        """(2, 3) map of crop pixels (u, v) to image pixels: c + side · R · ((u, v) / size − ½)."""
        c, s = np.cos(self.angle), np.sin(self.angle)
        rot = self.side / size * np.array([[c, -s], [s, c]])
        offset = np.array([self.cx, self.cy]) - rot @ np.array([size / 2, size / 2])
        return np.column_stack([rot, offset])


def roi_from_points(centre: np.ndarray, scale_point: np.ndarray) -> Roi:
    """The ROI of AlignmentPointsRects + RectTransformation in pose_detection_to_roi and
    pose_landmarks_to_roi: centre at `centre (2,)` px, side 2·|scale_point − centre| × 1.25
    (square_long of a square), rotated so that centre → scale_point points up
    (rotation_vector_target_angle_degrees 90)."""
    d = np.asarray(scale_point, np.float64) - np.asarray(centre, np.float64)
    angle = np.pi / 2 - np.arctan2(-d[1], d[0])
    angle = (angle + np.pi) % (2 * np.pi) - np.pi  # NormalizeRadians
    side = 2.0 * float(np.hypot(*d)) * ROI_SCALE
    return Roi(float(centre[0]), float(centre[1]), side, float(angle))


# ---------------------------------------------------------------- landmarks


@dataclass(frozen=True)
class Landmarks:
    """One landmark pass on one ROI.

    points: (39, 4) x px, y px, visibility, presence (sigmoid applied); world: (33, 3) metres,
    rotated back to the image's axes; presence: pose presence score (Identity_1).
    """

    points: np.ndarray
    world: np.ndarray
    presence: float


def refine_from_heatmap(
    xy: np.ndarray,
    heatmap: np.ndarray,
    *,
    kernel: int = HEATMAP_KERNEL,
    min_confidence: float = HEATMAP_MIN_CONFIDENCE,
) -> np.ndarray:
    """(K, 2) crop-normalised points moved to the sigmoid-weighted mean of their heatmap
    `(H, W, K)` logits in a `kernel` window (RefineLandmarksFromHeatmap); points outside the
    map or whose window peaks below `min_confidence` stay. Mean at cell index / W, as there."""
    h, w, k = heatmap.shape
    col = np.floor(xy[:, 0] * w).astype(int)
    row = np.floor(xy[:, 1] * h).astype(int)
    half = (kernel - 1) // 2
    offs = np.arange(-half, half + 1)
    cols = col[:, None] + offs  # (K, kernel)
    rows = row[:, None] + offs
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
    cvalid = (cols >= 0) & (cols < w)  # the window shrinks at the edges
    rvalid = (rows >= 0) & (rows < h)
    conf = sigmoid(
        heatmap[
            np.clip(rows, 0, h - 1)[:, :, None],
            np.clip(cols, 0, w - 1)[:, None, :],
            np.arange(k)[:, None, None],
        ]
    )  # (K, kernel, kernel): rows × cols
    conf = conf * (rvalid[:, :, None] & cvalid[:, None, :])
    total = conf.sum(axis=(1, 2))
    x = (conf.sum(axis=1) * cols).sum(axis=1) / np.maximum(total, 1e-12) / w
    y = (conf.sum(axis=2) * rows).sum(axis=1) / np.maximum(total, 1e-12) / h
    ok = inside & (conf.max(axis=(1, 2)) >= min_confidence) & (total > 0)
    return np.where(ok[:, None], np.column_stack([x, y]), xy)


def landmark_input(image: np.ndarray, roi: Roi, hide: Iterable[Disc] = ()) -> np.ndarray:
    """(1, 256, 256, 3) RGB in [0, 1]: the rotated ROI, replicated border (ImageToTensor's
    default BORDER_REPLICATE in pose_landmark_by_roi_cpu), with the discs `hide` (image px)
    painted mid-grey."""
    to_image = roi.crop_transform()
    crop = warp(image, to_image, LANDMARK_SIZE, cv2.BORDER_REPLICATE)
    scale = LANDMARK_SIZE / roi.side
    for (x, y), radius in hide:
        u, v = np.linalg.solve(to_image[:, :2], np.array([x, y]) - to_image[:, 2])
        cv2.circle(crop, (round(u), round(v)), round(radius * scale), HIDE_GREY, -1)
    return (crop / 255.0)[None]


def decode_landmarks(outputs: dict[str, np.ndarray], roi: Roi) -> Landmarks:
    """Landmarks of one landmark-model pass on `roi` (TensorsToPoseLandmarksAndSegmentation,
    then LandmarkProjection and WorldLandmarkProjection). The heatmap refinement brings the
    median distance to mediapipe's landmarks from 2.9-4.2 % to 0.9-1.5 % of torso length
    (Pose2Sim cameras at 60 fps, Sports2D)."""
    raw = outputs["Identity"].reshape(N_POINTS, 5)
    xy = raw[:, :2] / LANDMARK_SIZE  # crop-normalised (input_image_width/height 256)
    xy = refine_from_heatmap(xy, outputs["Identity_3"])
    px = to_pixels(xy, roi.crop_transform(), LANDMARK_SIZE)
    points = np.column_stack([px, sigmoid(raw[:, 3]), sigmoid(raw[:, 4])])
    c, s = np.cos(roi.angle), np.sin(roi.angle)
    world = outputs["Identity_4"].reshape(N_POINTS, 3)[:N_LANDMARKS].astype(np.float64)
    world[:, :2] = world[:, :2] @ np.array([[c, -s], [s, c]]).T
    return Landmarks(points, world, float(np.ravel(outputs["Identity_1"])[0]))


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


def next_roi(points: np.ndarray) -> Roi:
    """The ROI for the next frame from the auxiliary points (pose_landmarks_to_roi)."""
    return roi_from_points(points[AUX[0], :2], points[AUX[1], :2])


# ---------------------------------------------------------------- tracks


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


# ---------------------------------------------------------------- the detector


class BlazePoseDetector:
    """BlazePose Full for several people at once, tracked; `detect_people` for everybody,
    `detect` for the person seen the most."""

    name = "blazepose"
    version = 3  # in the detection cache key: bump when a video gives other output (3: hiding)
    skeleton = BLAZEPOSE33.name

    def __init__(
        self,
        config: DetectorConfig | None = None,
        *,
        video: object = None,
        threads: int | None = None,
    ) -> None:
        self.config = config or DetectorConfig()
        self.threads = threads or os.cpu_count() or 1
        detector_path, landmark_path = model_paths()
        self._detector = _Model(detector_path, self.threads)
        self._landmarks = _Model(landmark_path, self.threads)
        self._anchors = ssd_anchors()

    # -- one model pass each

    def find_people(self, image: np.ndarray) -> Detections:
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
        return Detections(
            boxes[keep],
            np.concatenate([f.keypoints for f in found])[keep],
            np.concatenate([f.scores for f in found])[keep],
            small[keep],
        )

    def _find_in_view(self, image: np.ndarray, to_image: np.ndarray) -> Detections:
        out = self._detector(detector_input(image, to_image))
        boxes, kps, scores = decode_detections(
            out["Identity"],
            out["Identity_1"],
            self._anchors,
            min_score=self.config.min_detection_confidence,
        )
        boxes, kps, scores = weighted_nms(boxes, kps, scores)
        corners = to_pixels(boxes.reshape(-1, 2, 2), to_image, DETECTOR_SIZE).reshape(-1, 4)
        return Detections(
            corners, to_pixels(kps, to_image, DETECTOR_SIZE), scores, np.zeros(len(scores), bool)
        )

    def landmarks(self, image: np.ndarray, roi: Roi, hide: Iterable[Disc] = ()) -> Landmarks:
        """One landmark pass on `roi` of an RGB uint8 image, the discs `hide` painted over."""
        return decode_landmarks(self._landmarks(landmark_input(image, roi, hide)), roi)

    # -- video

    def detect_people(self, frames: Iterable[Frame]) -> MultiPose2D:
        """Everybody, tracked: keypoints (T, P, 33, 3) x px, y px, visibility; world (T, P, 33, 3)
        metres; ids (T, P) track ids (-1 = empty slot); NaN where a slot is empty."""
        tracker = _Tracker(self)
        times: list[float] = []
        people: list[np.ndarray] = []
        worlds: list[np.ndarray] = []
        ids: list[np.ndarray] = []
        size: tuple[int, int] | None = None
        for t, image in frames:
            size = size or (image.shape[1], image.shape[0])
            kp, wd, tid = tracker.step(float(t), image)
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


class _Tracker:
    """Frame-by-frame state of `detect_people`: the live tracks and the detector's clock."""

    def __init__(self, detector: BlazePoseDetector) -> None:
        self.det = detector
        self.cfg = detector.config
        self.tracks: list[_Track] = []
        self.next_id = 0
        self.last_detection: float | None = None

    def step(self, t: float, image: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """((N, 33, 3) keypoints, (N, 33, 3) world, (N,) ids) of the people in this frame."""
        found: list[tuple[_Track, Landmarks]] = []
        lost = False
        for track in self.tracks:
            lm = self.det.landmarks(image, track.roi)
            if lm.presence >= self.cfg.min_tracking_confidence:
                found.append((track, lm))
            else:
                lost = True
        found = self._unique(image, found)
        if lost or not found or self._detection_due(t):
            found += self._new_people(t, image, found)
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
        self, t: float, image: np.ndarray, found: list[tuple[_Track, Landmarks]]
    ) -> list[tuple[_Track, Landmarks]]:
        """Tracks for detected people not already followed, strongest first, up to max_people."""
        self.last_detection = t
        if len(found) >= self.cfg.max_people:
            return []
        dets = self.det.find_people(image)
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
