"""BlazePose post-processing: the person detector's outputs decoded into face boxes and
keypoints (SSD anchors, score sigmoid, weighted non-maximum suppression), and the landmark
model's into landmarks in image pixels and world metres (heatmap refinement, projection back
through the crop)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gesturebank.extract.detectors.blazepose.preprocess import DETECTOR_SIZE, LANDMARK_SIZE, Roi

N_POINTS = 39  # 33 landmarks + 2 auxiliary (ROI) points + 4 unused
N_LANDMARKS = 33
NMS_IOU = 0.3  # pose_detection_cpu: NonMaxSuppression min_suppression_threshold (WEIGHTED)
HEATMAP_KERNEL = 7  # RefineLandmarksFromHeatmap kernel_size
HEATMAP_MIN_CONFIDENCE = 0.5  # its min_confidence_to_refine (proto default)


def sigmoid(x: np.ndarray) -> np.ndarray:
    """Logistic function in float64 (float32 overflows exp at the ±100 clip)."""
    return 1.0 / (1.0 + np.exp(-np.asarray(x, np.float64)))


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
class PersonBoxes:
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


def decode_detections(
    raw: np.ndarray,
    logits: np.ndarray,
    *,
    anchors: np.ndarray,
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
    boxes: np.ndarray, keypoints: np.ndarray, *, scores: np.ndarray, iou: float = NMS_IOU
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


def to_pixels(points: np.ndarray, to_image: np.ndarray, *, size: int) -> np.ndarray:
    """(..., 2) points normalised to a `size` tensor → image pixels through `to_image` (2, 3);
    for the letterbox this is DetectionLetterboxRemoval followed by the image size."""
    p = np.asarray(points) * size
    return p @ to_image[:, :2].T + to_image[:, 2]


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


def decode_landmarks(outputs: dict[str, np.ndarray], roi: Roi) -> Landmarks:
    """Landmarks of one landmark-model pass on `roi` (TensorsToPoseLandmarksAndSegmentation,
    then LandmarkProjection and WorldLandmarkProjection). The heatmap refinement brings the
    median distance to mediapipe's landmarks from 2.9-4.2 % to 0.9-1.5 % of torso length
    (Pose2Sim cameras at 60 fps, Sports2D)."""
    raw = outputs["Identity"].reshape(N_POINTS, 5)
    xy = raw[:, :2] / LANDMARK_SIZE  # crop-normalised (input_image_width/height 256)
    xy = refine_from_heatmap(xy, outputs["Identity_3"])
    px = to_pixels(xy, roi.crop_transform(), size=LANDMARK_SIZE)
    points = np.column_stack([px, sigmoid(raw[:, 3]), sigmoid(raw[:, 4])])
    c, s = np.cos(roi.angle), np.sin(roi.angle)
    world = outputs["Identity_4"].reshape(N_POINTS, 3)[:N_LANDMARKS].astype(np.float64)
    world[:, :2] = world[:, :2] @ np.array([[c, -s], [s, c]]).T
    return Landmarks(points, world, float(np.ravel(outputs["Identity_1"])[0]))
