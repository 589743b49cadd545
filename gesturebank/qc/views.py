"""Framing of a clip (the clip filters of youtube-gesture-dataset): facing away, seen from the
side, and a multi-camera take's view as every camera sees it; pure functions over keypoints
(`qc.metrics` measures a clip with them).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from gesturebank.geometry import torso_vectors
from gesturebank.skeletons import COCO17

if TYPE_CHECKING:
    from gesturebank.geometry import Camera
    from gesturebank.poses import Pose3D

_I = COCO17.index


def _torso_axes(xy: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per frame `(T,)`: the right → left shoulder vector `(T, 2)`, the torso's up vector
    `(T, 2)` (mid-hips → mid-shoulders, or mid-shoulders → nose where the hips are unseen) and
    whether both were seen. Image coordinates (y down); the body may lean any way."""
    ls, rs, nose = _I["left_shoulder"], _I["right_shoulder"], _I["nose"]
    lh, rh = _I["left_hip"], _I["right_hip"]
    across, up = torso_vectors(xy[:, ls], xy[:, rs], left_hip=xy[:, lh], right_hip=xy[:, rh])
    hips = valid[:, lh] & valid[:, rh]
    up = np.where(hips[:, None], up, xy[:, nose] - (xy[:, ls] + xy[:, rs]) / 2)
    seen = valid[:, ls] & valid[:, rs] & (hips | valid[:, nose])
    return across, up, seen


def facing_away(xy: np.ndarray, valid: np.ndarray) -> NDArray[np.bool_]:
    """`(T,)` frames where the person faces away from the camera: seen from the front, their
    left shoulder lies to the right of the torso's up direction; from behind, to the left
    (youtube-gesture-dataset's rule — right shoulder right of the left — made independent of a
    lean). `xy (T, 17, 2)` COCO-17 pixels, `valid (T, 17)`."""
    turn, seen = _turn(xy, valid)
    with np.errstate(invalid="ignore"):
        return np.asarray(seen & (turn > 0))


def _turn(xy: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`(T,)` the torso's turn (< 0 seen from the front, > 0 from behind, image y down) and
    whether the torso was seen."""
    across, up, seen = _torso_axes(xy, valid)
    return across[:, 0] * up[:, 1] - across[:, 1] * up[:, 0], seen


def sideways(xy: np.ndarray, valid: np.ndarray) -> NDArray[np.bool_]:
    """`(T,)` frames where the nose lies beyond a shoulder along the shoulder line (a side view;
    youtube-gesture-dataset's "nose outside the shoulders", measured along the shoulders rather
    than the image's x axis so that a lean is not a side view)."""
    along, seen = nose_along(xy, valid)
    with np.errstate(invalid="ignore"):
        return np.asarray(seen & (np.abs(along) > 0.5))


def nose_along(xy: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`(T,)` where the nose lies along the shoulder line (0 between the shoulders, ±0.5 on a
    shoulder) and whether the nose and both shoulders were seen."""
    ls, rs, nose = _I["left_shoulder"], _I["right_shoulder"], _I["nose"]
    across = xy[:, ls] - xy[:, rs]
    offset = xy[:, nose] - (xy[:, ls] + xy[:, rs]) / 2
    seen = valid[:, ls] & valid[:, rs] & valid[:, nose]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sum(offset * across, axis=-1) / np.sum(across * across, axis=-1), seen


# A multi-camera take is judged by its 3D as each of its cameras sees it: the triangulated joints
# projected into every camera. Facing away and sideways only mean something relative to a camera,
# so the take's rule is the single camera's rule applied to every camera at once: a frame faces
# away when it faces away from every camera (one camera seeing the front is enough to triangulate
# the hands in front of the body), and is seen from the side when every camera sees it so. A
# camera the torso lies behind (its projection is NaN) sees neither the front nor a square view.


def facing_away_from_all(views: Sequence[np.ndarray], valid: np.ndarray) -> NDArray[np.bool_]:
    """`(T,)` frames whose torso faces away from every camera: `views` one `(T, 17, 2)` COCO-17
    projection per camera of the same 3D pose, `valid (T, 17)` its seen joints."""
    away = np.ones(len(valid), dtype=bool)
    seen = np.zeros(len(valid), dtype=bool)
    for xy in views:
        turn, seen = _turn(xy, valid)
        with np.errstate(invalid="ignore"):
            away &= ~(turn < 0)  # NaN: this camera does not see the front
    return np.asarray(seen & away)


def sideways_from_all(views: Sequence[np.ndarray], valid: np.ndarray) -> NDArray[np.bool_]:
    """`(T,)` frames that every camera of `views` (as `facing_away_from_all`) sees from the
    side: in none of them does the nose lie between the shoulders."""
    side = np.ones(len(valid), dtype=bool)
    seen = np.zeros(len(valid), dtype=bool)
    for xy in views:
        along, seen = nose_along(xy, valid)
        with np.errstate(invalid="ignore"):
            side &= ~(np.abs(along) <= 0.5)
    return np.asarray(seen & side)


def take_cameras(pose3d: Pose3D) -> list[Camera]:
    """The cameras a multi-camera take's 3D was triangulated from; [] for a single camera."""
    return [] if pose3d.cameras is None else list(pose3d.cameras)


def _shoulder_width(xy: np.ndarray, shoulders: np.ndarray, height: float) -> float:
    """Median shoulder width of `xy (T, 17, 2)` pixels over the `shoulders` frames, as a share
    of the frame `height`; NaN when there are none."""
    width = np.linalg.norm(xy[:, _I["left_shoulder"]] - xy[:, _I["right_shoulder"]], axis=-1)
    return float(np.median(width[shoulders]) / float(height)) if shoulders.any() else float("nan")


def _share(flags: np.ndarray, among: np.ndarray) -> float:
    n = int(np.sum(among))
    return float(np.sum(flags) / n) if n else float("nan")
