"""The head's rotation from the face mesh (issue 40): the face landmark model's 468 points with
depth (`extract.mouth.FaceLandmarker`) fitted rigidly, with scale (Umeyama), to a reference face.

The reference (`gesturebank/data/face-reference.csv`) is the same model's mesh of the face photo
the truth renderer paints on its figures' heads (scikit-image's astronaut, NASA, public domain;
`synth.looks`), measured once by `benchmarks/face_reference.py`, in the photo's own axes: x to
the image's right (the person's left), y down, z away from the camera. The renderer maps that
photo orthographically onto the head's front, so the photo's axes are the head's: its zero is the
head's zero (a portrait facing the camera; its eye line tilts 2° in the photo).

Only the upper face is fitted (`STABLE`: the points above the upper lip, i.e. forehead, brows,
eyes, nose and cheeks): the mouth and jaw move with speech. The mesh comes in the crop's
weak-perspective axes; a face off the image centre is seen along its own ray, so the rotation in
the camera's axes is the fitted one turned from the optical axis onto that ray (`on_ray`).

A fit is kept where the model saw a face (presence) and the upper face fits the reference within
`max_fit_residual` (RMS, share of the reference face's height after scaling).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from importlib import resources

import numpy as np

from gesturebank.errors import InputError
from gesturebank.extract.detectors.blazepose import Roi
from gesturebank.extract.mouth import CROP_PER_WIDTH, FACE_POINTS, WIDTH_PER_EYES
from gesturebank.skeletons import COCO17, get_skeleton

REFERENCE_FILE = "face-reference.csv"
N_POINTS = 468
UPPER_LIP_OUTER = 0  # the upper lip's outer centre on the canonical face mesh
FOREHEAD, CHIN = 10, 152
# The head's axes (columns forward, left, up) in the reference's axes (x right, y down, z away):
# the face looks towards the camera (−z), the person's left is the image's right.
HEAD_IN_REFERENCE = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0]])
# Face width over the nose-to-ear distance (adults: about 145 mm over 100-110 mm), which a turned
# face does not foreshorten as it does the eye distance.
WIDTH_PER_EAR_NOSE = 1.4
# The face model's presence probability (on the crop from the first mesh, `mesh_roi`) below which
# a crop gives no head. Lower than the mouth's (0.5): a face turned 50-70° from the camera often
# scores 0.1-0.5 and still gives its turn (test.bvh 0–6 s rendered at 60°: yaw error 10.9° over
# the 46 of 52 frames ≥ 0.1, 10.5° over the 35 ≥ 0.5).
MIN_HEAD_PRESENCE = 0.1
EYE_CORNERS = (33, 263)  # the right and left eyes' outer corners on the canonical face mesh
# A crop from a mesh: its bounding box enlarged this much (as mediapipe's face pipeline tracks a
# face from its previous landmarks).
MESH_CROP_SCALE = 1.5


def head_box(
    *,
    keypoints: np.ndarray,
    skeleton: str,
    min_confidence: float,
    max_turn: float,
    min_px: float,
) -> tuple[Roi | None, str]:
    """The square face crop for the head's pose of one person in one frame, or None with the
    reason: `extract.mouth.face_box`'s crop (nose and eyes seen, the left eye on the image's
    right, turned at most `max_turn`), its face width the larger of the eyes' estimate and
    WIDTH_PER_EAR_NOSE × the farthest seen ear from the nose (BlazePose pulls a turned face's
    eyes together, so the eyes alone make it too small), at least `min_px` wide."""
    coco = get_skeleton(skeleton).convert(np.asarray(keypoints)[None], COCO17)[0]
    pt = [coco[COCO17.index[name]] for name in FACE_POINTS]
    if not all(np.isfinite(p[0]) and p[2] >= min_confidence for p in pt):
        return None, "face unseen"
    nose, left_eye, right_eye = (p[:2].astype(np.float64) for p in pt)
    eye_line = left_eye - right_eye
    if eye_line[0] <= 0:
        return None, "facing away"
    eyes = float(np.hypot(*eye_line))
    turn = abs(float(np.dot(nose - (left_eye + right_eye) / 2, eye_line))) / (eyes * eyes / 2)
    if turn > max_turn:
        return None, "facing away"
    width = WIDTH_PER_EYES * eyes * float(np.sqrt(1 + turn * turn))
    for ear in (coco[COCO17.index["left_ear"]], coco[COCO17.index["right_ear"]]):
        if np.isfinite(ear[0]) and ear[2] >= min_confidence:
            width = max(width, WIDTH_PER_EAR_NOSE * float(np.hypot(*(ear[:2] - nose))))
    if width < min_px:
        return None, "face too small"
    angle = float(np.arctan2(eye_line[1], eye_line[0]))
    return Roi(float(nose[0]), float(nose[1]), CROP_PER_WIDTH * width, angle), ""


def mesh_roi(points: np.ndarray) -> Roi:
    """The square crop around face-mesh `points (468, ≥2)` image px: centred on their bounding
    box, MESH_CROP_SCALE × its longer side, turned so the eye corners are level. The head's
    pose runs the model again on it: a crop placed from the body's keypoints is off-centre and
    too small on a turned face, and the mesh then turns too little (test.bvh 0–6 s rendered at
    60°: yaw error 18° → 11° with one such pass)."""
    p = np.asarray(points, np.float64)[:, :2]
    lo, hi = p.min(axis=0), p.max(axis=0)
    eye = p[EYE_CORNERS[1]] - p[EYE_CORNERS[0]]
    centre = (lo + hi) / 2
    side = MESH_CROP_SCALE * float(np.max(hi - lo))
    return Roi(float(centre[0]), float(centre[1]), side, float(np.arctan2(eye[1], eye[0])))


@cache
def reference_face() -> np.ndarray:
    """(468, 3) float64 reference mesh (module docstring), photo pixels."""
    path = resources.files("gesturebank") / "data" / REFERENCE_FILE
    text = path.read_text(encoding="utf-8")
    rows = [line for line in text.splitlines() if line and not line.startswith("#")]
    try:
        points = np.array([[float(v) for v in row.split(",")] for row in rows[1:]], np.float64)
    except ValueError:
        raise InputError(f"{path}: not a table of x,y,z numbers") from None
    if points.shape != (N_POINTS, 3):
        raise InputError(f"{path}: expected {N_POINTS} rows of x,y,z, got {points.shape}")
    return points


@cache
def stable_points() -> np.ndarray:
    """Indices of the reference's upper-face points (above the upper lip's outer centre)."""
    ref = reference_face()
    return np.flatnonzero(ref[:, 1] < ref[UPPER_LIP_OUTER, 1])


def rigid_fit(
    source: np.ndarray, target: np.ndarray
) -> tuple[np.ndarray, float, np.ndarray, float]:
    """Rotation R (3, 3), scale s, translation t (3,) minimising Σ |target − (s·R·source + t)|²
    over the rows of `source`, `target` (N, 3) (Umeyama 1991), and the RMS residual. R is a
    proper rotation (det +1) even when the best orthogonal map would be a reflection."""
    x = np.asarray(source, np.float64)
    y = np.asarray(target, np.float64)
    mx, my = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - mx, y - my
    var = float(np.sum(xc * xc)) / len(x)
    u, d, vt = np.linalg.svd(yc.T @ xc / len(x))
    sign = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(u @ vt)) or 1.0)])
    r = u @ sign @ vt
    s = float(np.sum(d * np.diag(sign))) / var if var > 0 else float("nan")
    t = my - s * r @ mx
    residual = y - (s * x @ r.T + t)
    return r, s, t, float(np.sqrt(np.mean(np.sum(residual * residual, axis=1))))


@dataclass(frozen=True)
class HeadFit:
    """One face's head: axes (3, 3) columns forward, left, up in the crop's weak-perspective
    camera axes (x right, y down, z away); centre (2,) image px of the fitted points; residual:
    RMS of the upper face after the fit, share of the fitted face's height."""

    axes: np.ndarray
    centre: np.ndarray
    residual: float


def fit_head(points: np.ndarray) -> HeadFit:
    """The head of one face mesh `points (468, 3)`: image px x, y and depth z (same scale, away
    from the camera), fitted to the reference face on its upper-face points."""
    ref = reference_face()
    keep = stable_points()
    p = np.asarray(points, np.float64)
    if p.shape != (N_POINTS, 3):
        raise InputError(f"fit_head: points must be ({N_POINTS}, 3), got {p.shape}")
    r, s, _, rms = rigid_fit(ref[keep], p[keep])
    height = s * float(np.linalg.norm(ref[FOREHEAD] - ref[CHIN]))
    return HeadFit(r @ HEAD_IN_REFERENCE, p[keep, :2].mean(axis=0), rms / height)


def on_ray(
    axes: np.ndarray, centre: np.ndarray, *, focal: np.ndarray, principal: np.ndarray
) -> np.ndarray:
    """(..., 3, 3) weak-perspective head axes `axes` of faces at image `centre (..., 2)` px, in
    the camera's axes: turned by the rotation that takes the optical axis onto each face's ray
    (pinhole `focal (2,)`, `principal (2,)` px)."""
    c = np.asarray(centre, np.float64)
    ray = np.concatenate([(c - principal) / focal, np.ones((*c.shape[:-1], 1))], axis=-1)
    ray /= np.linalg.norm(ray, axis=-1, keepdims=True)
    # Rodrigues' rotation from ẑ to the ray: axis ẑ × ray, cos = ray_z.
    k = np.stack([-ray[..., 1], ray[..., 0], np.zeros_like(ray[..., 0])], axis=-1)
    cos = ray[..., 2]
    kx = np.zeros((*cos.shape, 3, 3))
    kx[..., 0, 2], kx[..., 1, 2] = k[..., 1], -k[..., 0]
    kx[..., 2, 0], kx[..., 2, 1] = -k[..., 1], k[..., 0]
    turn = np.eye(3) + kx + (kx @ kx) / (1.0 + cos)[..., None, None]
    return turn @ np.asarray(axes, np.float64)


@dataclass(frozen=True)
class HeadPoses:
    """Per tracked person, on the take's T video frames: axes (T, M, 3, 3) weak-perspective head
    axes (`HeadFit.axes`), centre (T, M, 2) px, residual (T, M); NaN where not measured.
    track_ids (M,) int64 as `extract.roles.Roles`."""

    track_ids: np.ndarray
    axes: np.ndarray
    centre: np.ndarray
    residual: np.ndarray

    @staticmethod
    def empty(track_ids: np.ndarray, n_frames: int) -> HeadPoses:
        m = len(track_ids)
        nan = np.nan
        return HeadPoses(
            np.asarray(track_ids, np.int64),
            np.full((n_frames, m, 3, 3), nan, np.float32),
            np.full((n_frames, m, 2), nan, np.float32),
            np.full((n_frames, m), nan, np.float32),
        )

    def of(self, track: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(axes (T, 3, 3), centre (T, 2), residual (T,)) of the person given per frame by
        `track (T,)` (-1 or an unknown id: NaN)."""
        n = len(track)
        axes = np.full((n, 3, 3), np.nan, np.float64)
        centre = np.full((n, 2), np.nan, np.float64)
        residual = np.full(n, np.nan, np.float64)
        column = {int(k): m for m, k in enumerate(self.track_ids)}
        for k in np.unique(track[track >= 0]):
            m = column.get(int(k))
            if m is not None:
                rows = track == k
                axes[rows] = self.axes[rows, m]
                centre[rows] = self.centre[rows, m]
                residual[rows] = self.residual[rows, m]
        return axes, centre, residual


def spread_heads(
    rows: np.ndarray, axes: np.ndarray, *, centre: np.ndarray, residual: np.ndarray, n_frames: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The sampled frames `rows (S,)` (increasing) onto all `n_frames`, per track: axes
    (S, M, 3, 3), centre (S, M, 2), residual (S, M) interpolated linearly between the two
    sampled frames around each frame (the axes made rotations again); NaN where either of them
    was not measured, and outside the sampled frames."""
    m = axes.shape[1]
    out_axes = np.full((n_frames, m, 3, 3), np.nan)
    out_centre = np.full((n_frames, m, 2), np.nan)
    out_res = np.full((n_frames, m), np.nan)
    if len(rows) == 0:
        return out_axes, out_centre, out_res
    frames = np.arange(n_frames)
    hi = np.clip(np.searchsorted(rows, frames), 0, len(rows) - 1)
    lo = np.clip(hi - 1, 0, len(rows) - 1)
    exact = rows[hi] == frames
    lo = np.where(exact, hi, lo)
    span = np.maximum(rows[hi] - rows[lo], 1)
    w = np.where(exact, 0.0, (frames - rows[lo]) / span)
    inside = (frames >= rows[0]) & (frames <= rows[-1])
    for src, dst in ((axes, out_axes), (centre, out_centre)):
        shape = (-1,) + (1,) * (src.ndim - 1)
        value = (1 - w.reshape(shape)) * src[lo] + w.reshape(shape) * src[hi]
        dst[inside] = value[inside]
    out_res[inside] = np.fmax(residual[lo], residual[hi])[inside]
    return orthonormal(out_axes), out_centre, out_res


def orthonormal(axes: np.ndarray) -> np.ndarray:
    """(..., 3, 3) the nearest rotations to `axes` (SVD); NaN stays NaN."""
    a = np.asarray(axes, np.float64)
    ok = np.isfinite(a).all(axis=(-2, -1))
    out = np.full(a.shape, np.nan)
    if ok.any():
        u, _, vt = np.linalg.svd(a[ok])
        d = np.sign(np.linalg.det(u @ vt))
        u[..., :, -1] *= d[..., None]
        out[ok] = u @ vt
    return out
