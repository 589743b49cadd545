"""BlazePose pre-processing: the squares the person detector looks through, the rotated crop
(region of interest, ROI) the landmark model sees, and the tensors made of them (ImageToTensor in
pose_detection_cpu and pose_landmark_by_roi_cpu).

Geometry in pixels: an ROI is a rotated square (centre, side, angle); a crop maps tensor pixel
(u, v) to image point c + side · R(angle) · ((u, v) / n − ½)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import cv2
import numpy as np

DETECTOR_SIZE = 224  # pose_detection_cpu: ImageToTensor output_tensor_width/height
LANDMARK_SIZE = 256  # pose_landmark_by_roi_cpu: ImageToTensor output_tensor_width/height
ROI_SCALE = 1.25  # pose_detection_to_roi / pose_landmarks_to_roi: scale_x, scale_y
# Frames this much longer than wide are also searched in square tiles (see detection_views).
TILE_ASPECT = 1.2
# The paint of the discs that hide a person in a crop (tracker.person_discs).
HIDE_GREY = (127.5, 127.5, 127.5)
Disc = tuple[tuple[float, float], float]  # centre (x, y) px, radius px


def square_transform(x0: float, y0: float, *, side: float, size: int = DETECTOR_SIZE) -> np.ndarray:
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
    views = [square_transform((width - long) / 2, (height - long) / 2, side=long)]
    if long >= TILE_ASPECT * short:
        for start in np.linspace(0, long - short, int(np.ceil(long / short))):
            x0, y0 = (start, 0.0) if width > height else (0.0, start)
            views.append(square_transform(x0, y0, side=short))
    if small and short / 2 >= DETECTOR_SIZE:
        side = short / 2
        xs, ys = (np.linspace(0, n - side, int(np.ceil(n / side)) + 1) for n in (width, height))
        views += [square_transform(x0, y0, side=side) for y0 in ys for x0 in xs]
    return views


def warp(image: np.ndarray, to_image: np.ndarray, *, size: int, border: int) -> np.ndarray:
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
    return (warp(image, to_image, size=DETECTOR_SIZE, border=cv2.BORDER_CONSTANT) / 127.5 - 1.0)[
        None
    ]


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


def landmark_input(image: np.ndarray, roi: Roi, *, hide: Iterable[Disc] = ()) -> np.ndarray:
    """(1, 256, 256, 3) RGB in [0, 1]: the rotated ROI, replicated border (ImageToTensor's
    default BORDER_REPLICATE in pose_landmark_by_roi_cpu), with the discs `hide` (image px)
    painted mid-grey."""
    to_image = roi.crop_transform()
    crop = warp(image, to_image, size=LANDMARK_SIZE, border=cv2.BORDER_REPLICATE)
    scale = LANDMARK_SIZE / roi.side
    for (x, y), radius in hide:
        u, v = np.linalg.solve(to_image[:, :2], np.array([x, y]) - to_image[:, 2])
        cv2.circle(crop, (round(u), round(v)), round(radius * scale), HIDE_GREY, -1)
    return (crop / 255.0)[None]
