"""Geometry every stage shares: axis rotations, vectors, the body frame and the pinhole camera.

It sits on the ground floor (numpy, scipy and gesturebank.errors only; OpenCV is imported where a
camera needs it), so that the lifters, the retargeting, mocap and the QC build these things one way.

Vectors: the component axis is `axis` (default last, `(..., 3)`); the retargeting keeps its
vectors component-first, `(3, T)`, and passes `axis=0`.

The body frame (one convention for the whole project): `up` points from the mid-hips to the
mid-shoulders; `left` from the right to the left shoulder, made orthogonal to `up`;
`forward = left × up`. The three are unit vectors and form a right-handed frame, so in a
right-handed world `forward` leaves the chest.

Cameras: a `Camera` maps world points to pixels, `x_cam = R @ X + t`, pinhole `K`, and OpenCV's
radial / tangential distortion `(k1, k2, p1, p2[, k3])`; world units are metres. A `CameraGroup`
is the ordered set of cameras of one take; arrays over it carry the camera axis first, `(C, ...)`.
Reading and writing calibration files (Pose2Sim/anipose TOML, Qualisys) stays with the
multi-view lifter (`gesturebank.camera_files`).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Self

import numpy as np
from scipy.spatial.transform import Rotation

from gesturebank.errors import CalibrationError

# --------------------------------------------------------------------------------------------------
# Rotations and vectors


def axis_rotations(axis: int, t: np.ndarray) -> np.ndarray:
    """(N, 3, 3) right-handed rotations by angles t (N,) rad about x (0), y (1) or z (2)."""
    c, s = np.cos(t), np.sin(t)
    r = np.zeros((*t.shape, 3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r[..., axis, axis] = 1.0
    r[..., i, i] = c
    r[..., j, j] = c
    r[..., i, j] = -s
    r[..., j, i] = s
    return r


def dot(a: np.ndarray, b: np.ndarray, *, axis: int = -1) -> np.ndarray:
    """Dot product of 3-vectors along `axis` (that axis removed)."""
    a0, a1, a2 = np.moveaxis(a, axis, 0)
    b0, b1, b2 = np.moveaxis(b, axis, 0)
    return np.asarray(a0 * b0 + a1 * b1 + a2 * b2)


def cross(a: np.ndarray, b: np.ndarray, *, axis: int = -1) -> np.ndarray:
    """Cross product a × b of 3-vectors along `axis`."""
    a0, a1, a2 = np.moveaxis(a, axis, 0)
    b0, b1, b2 = np.moveaxis(b, axis, 0)
    out = np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
    return np.moveaxis(out, 0, axis)


def unit(v: np.ndarray, *, axis: int = -1) -> np.ndarray:
    """`v` divided by its length along `axis` (a zero or NaN vector gives NaN)."""
    return np.asarray(v / np.expand_dims(np.sqrt(dot(v, v, axis=axis)), axis))


# --------------------------------------------------------------------------------------------------
# The body frame


def torso_vectors(
    left_shoulder: np.ndarray,
    right_shoulder: np.ndarray,
    *,
    left_hip: np.ndarray,
    right_hip: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The torso's `(across, up)` vectors, not normalised, in any dimension (2D image points
    too): across = right → left shoulder, up = mid-hips → mid-shoulders."""
    mid_shoulders = (left_shoulder + right_shoulder) / 2
    return left_shoulder - right_shoulder, mid_shoulders - (left_hip + right_hip) / 2


def frame_from(
    across: np.ndarray, up: np.ndarray, *, axis: int = -1
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit `(forward, left, up)` from an up vector and a right → left vector (any lengths):
    left is `across` made orthogonal to `up`, forward = left × up (right-handed)."""
    up = unit(up, axis=axis)
    left = across - np.expand_dims(dot(across, up, axis=axis), axis) * up
    left = unit(left, axis=axis)
    return cross(left, up, axis=axis), left, up


def body_frame(
    left_shoulder: np.ndarray,
    right_shoulder: np.ndarray,
    *,
    left_hip: np.ndarray,
    right_hip: np.ndarray,
    axis: int = -1,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The body frame (module docstring): unit `(forward, left, up)` from 3D shoulders and hips,
    per frame (NaN where a point is missing)."""
    across, up = torso_vectors(
        left_shoulder, right_shoulder, left_hip=left_hip, right_hip=right_hip
    )
    return frame_from(across, up, axis=axis)


def similarity(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Scale, rotation (3, 3) and translation (3,) with `dst ≈ s R src + t` in least squares,
    for matching points (N, 3) each, N ≥ 3 not on one line (Umeyama 1991, eqs. 40–42)."""
    src, dst = np.asarray(src, np.float64), np.asarray(dst, np.float64)
    ms, md = src.mean(0), dst.mean(0)
    u, sv, vt = np.linalg.svd((dst - md).T @ (src - ms))
    d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])  # a rotation, never a reflection
    rot = u @ d @ vt
    scale = float((sv * np.diag(d)).sum() / ((src - ms) ** 2).sum())
    return scale, rot, md - scale * rot @ ms


# --------------------------------------------------------------------------------------------------
# The pinhole camera


# scipy rather than cv2.Rodrigues: OpenCV returns a zero vector for rotations under 1e-5 rad,
# so a nearly aligned camera would not survive a save/load round trip.
def rodrigues_to_matrix(rvec: np.ndarray) -> np.ndarray:
    """(3, 3) rotation of a Rodrigues (rotation) vector (3,)."""
    return Rotation.from_rotvec(np.asarray(rvec, np.float64).reshape(3)).as_matrix()


def matrix_to_rodrigues(rotation: np.ndarray) -> np.ndarray:
    """(3,) Rodrigues vector of a rotation matrix (3, 3)."""
    return Rotation.from_matrix(np.asarray(rotation, np.float64)).as_rotvec()


@dataclass(frozen=True, eq=False)
class Camera:
    """One calibrated camera.

    name: identifier (matched against video stems); size: (width, height) px;
    K: (3, 3) intrinsics; dist: (D,) OpenCV distortion, D in {0, 4, 5, 8, 12, 14};
    R: (3, 3) rotation world → camera; t: (3,) translation world → camera, metres.
    """

    name: str
    size: tuple[int, int]
    K: np.ndarray
    dist: np.ndarray
    R: np.ndarray
    t: np.ndarray

    def __post_init__(self) -> None:
        what = f"camera {self.name!r}"
        K = np.asarray(self.K, np.float64)
        dist = np.asarray(self.dist, np.float64).ravel()
        R = np.asarray(self.R, np.float64)
        t = np.asarray(self.t, np.float64).ravel()
        if K.shape != (3, 3) or not np.all(np.isfinite(K)) or K[0, 0] <= 0 or K[1, 1] <= 0:
            raise CalibrationError(f"{what}: matrix must be a finite 3x3 with positive focals")
        if dist.size not in (0, 4, 5, 8, 12, 14) or not np.all(np.isfinite(dist)):
            raise CalibrationError(f"{what}: distortions must hold 0, 4, 5, 8, 12 or 14 numbers")
        if R.shape == (3,):
            R = rodrigues_to_matrix(R)
        if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-5):
            raise CalibrationError(f"{what}: rotation is not a rotation matrix")
        if abs(np.linalg.det(R) - 1.0) > 1e-5:
            raise CalibrationError(f"{what}: rotation has a reflection (det = -1)")
        if t.shape != (3,) or not np.all(np.isfinite(t)):
            raise CalibrationError(f"{what}: translation must be 3 finite numbers")
        w, h = (round(float(v)) for v in self.size)
        if w <= 0 or h <= 0:
            raise CalibrationError(f"{what}: size must be positive, got {self.size}")
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "dist", dist)
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "size", (w, h))

    @property
    def rvec(self) -> np.ndarray:
        """(3,) Rodrigues vector of R."""
        return matrix_to_rodrigues(self.R)

    @property
    def extrinsics(self) -> np.ndarray:
        """(3, 4) `[R | t]`: world → camera; the projection matrix in normalised coordinates."""
        return np.hstack([self.R, self.t[:, None]])

    @property
    def projection(self) -> np.ndarray:
        """(3, 4) `K [R | t]`: world → undistorted pixels (homogeneous)."""
        return self.K @ self.extrinsics

    @property
    def center(self) -> np.ndarray:
        """(3,) optical centre in world coordinates."""
        return -self.R.T @ self.t

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """World points (..., 3) → camera-frame points (..., 3)."""
        return np.asarray(points, np.float64) @ self.R.T + self.t

    def distort(self, normalised: np.ndarray) -> np.ndarray:
        """Ideal normalised coordinates (..., 2) → distorted pixels (..., 2); NaN stays NaN."""
        xy = np.asarray(normalised, np.float64)
        d = np.zeros(5)
        d[: min(5, self.dist.size)] = self.dist[:5]
        if self.dist.size > 5:
            # Rational / thin-prism / tilted models: let OpenCV do it (rare in practice).
            return self._project_opencv(np.concatenate([xy, np.ones_like(xy[..., :1])], -1))
        k1, k2, p1, p2, k3 = d
        x, y = xy[..., 0], xy[..., 1]
        r2 = x * x + y * y
        radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
        yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
        u = self.K[0, 0] * xd + self.K[0, 1] * yd + self.K[0, 2]
        v = self.K[1, 1] * yd + self.K[1, 2]
        return np.stack([u, v], axis=-1)

    def _project_opencv(self, cam_points: np.ndarray) -> np.ndarray:
        import cv2

        flat = cam_points.reshape(-1, 3)
        out = np.full((len(flat), 2), np.nan)
        ok = np.all(np.isfinite(flat), axis=1)
        if ok.any():
            z = np.zeros(3)
            px, _ = cv2.projectPoints(flat[ok], z, z, self.K, self.dist)
            out[ok] = px.reshape(-1, 2)
        return out.reshape(*cam_points.shape[:-1], 2)

    def project(self, points: np.ndarray) -> np.ndarray:
        """World points (..., 3) → distorted pixel coordinates (..., 2).

        Points on or behind the image plane (z ≤ 0) project to NaN: they are not visible.
        """
        cam = self.to_camera(points)
        z = cam[..., 2:3]
        with np.errstate(divide="ignore", invalid="ignore"):
            normalised = np.where(z > 0, cam[..., :2] / z, np.nan)
        return self.distort(normalised)

    def undistort_points(self, pixels: np.ndarray, *, normalised: bool = False) -> np.ndarray:
        """Distorted pixels (..., 2) → ideal pinhole pixels (..., 2), or normalised coordinates
        (x/z, y/z) with `normalised=True`. NaN stays NaN."""
        import cv2

        px = np.asarray(pixels, np.float64)
        flat = px.reshape(-1, 2)
        out = np.full_like(flat, np.nan)
        ok = np.all(np.isfinite(flat), axis=1)
        if ok.any():
            # The iterative solver converges where OpenCV's default 5 iterations do not
            # (strong distortion near the image border).
            criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-10)
            und = cv2.undistortPoints(
                flat[ok].reshape(-1, 1, 2),
                self.K,
                self.dist,
                R=np.eye(3),
                P=np.eye(3),
                criteria=criteria,
            )
            out[ok] = und.reshape(-1, 2)
        if not normalised:
            out = out @ self.K[:2, :2].T + self.K[:2, 2]
        return out.reshape(px.shape)

    def to_dict(self) -> dict[str, Any]:
        """The Pose2Sim/anipose TOML table of this camera."""
        return {
            "name": self.name,
            "size": [float(self.size[0]), float(self.size[1])],
            "matrix": self.K.tolist(),
            "distortions": self.dist.tolist(),
            "rotation": self.rvec.tolist(),
            "translation": self.t.tolist(),
            "fisheye": False,
        }

    @classmethod
    def from_dict(cls, table: dict[str, Any], *, key: str = "", source: str = "") -> Camera:
        """A camera from one TOML table; CalibrationError naming the file and table if bad."""
        where = f"{source}: [{key}]" if source else f"[{key}]"
        missing = [k for k in ("size", "matrix", "rotation", "translation") if k not in table]
        if missing:
            raise CalibrationError(f"{where}: missing {', '.join(missing)}")
        if table.get("fisheye", False):
            raise CalibrationError(f"{where}: fisheye cameras are not supported")
        try:
            return cls(
                name=str(table.get("name", key)),
                size=tuple(table["size"]),
                K=np.asarray(table["matrix"], np.float64),
                dist=np.asarray(table.get("distortions", []), np.float64),
                R=np.asarray(table["rotation"], np.float64),
                t=np.asarray(table["translation"], np.float64),
            )
        except CalibrationError as exc:
            raise CalibrationError(f"{where}: {exc}") from None
        except (TypeError, ValueError) as exc:
            raise CalibrationError(f"{where}: malformed camera table ({exc})") from None


class CameraGroup(Sequence[Camera]):
    """The ordered cameras of one take. Array arguments carry the camera axis first: (C, ...)."""

    def __init__(self, cameras: Sequence[Camera]) -> None:
        cams = list(cameras)
        if not cams:
            raise CalibrationError("a camera group needs at least one camera")
        names = [c.name for c in cams]
        if len(set(names)) != len(names):
            raise CalibrationError(f"camera names repeat: {names}")
        self.cameras: tuple[Camera, ...] = tuple(cams)

    def __len__(self) -> int:
        return len(self.cameras)

    def __getitem__(self, index: int) -> Camera:  # type: ignore[override]
        return self.cameras[index]

    def __iter__(self) -> Iterator[Camera]:
        return iter(self.cameras)

    @property
    def names(self) -> list[str]:
        return [c.name for c in self.cameras]

    def subset(self, names: Sequence[str]) -> Self:
        """The cameras called `names`, in that order (a group of the same class)."""
        by_name = {c.name: c for c in self.cameras}
        unknown = [n for n in names if n not in by_name]
        if unknown:
            raise CalibrationError(f"unknown cameras {unknown}; have {self.names}")
        return type(self)([by_name[n] for n in names])

    def project(self, points: np.ndarray) -> np.ndarray:
        """World points (..., 3) → pixels in every camera (C, ..., 2)."""
        return np.stack([c.project(points) for c in self.cameras])

    def undistort_points(self, pixels: np.ndarray, *, normalised: bool = False) -> np.ndarray:
        """Pixels (C, ..., 2) → ideal pixels (or normalised coordinates) (C, ..., 2)."""
        px = np.asarray(pixels, np.float64)
        if px.shape[0] != len(self):
            raise CalibrationError(f"expected points for {len(self)} cameras, got {px.shape[0]}")
        return np.stack(
            [c.undistort_points(p, normalised=normalised) for c, p in zip(self, px, strict=True)]
        )

    def to_tables(self) -> list[dict[str, Any]]:
        """Every camera's TOML table (`Camera.to_dict`), in order."""
        return [c.to_dict() for c in self.cameras]

    @classmethod
    def from_tables(cls, tables: Sequence[dict[str, Any]], *, source: str = "") -> CameraGroup:
        """The group of `to_tables`; CalibrationError naming `source` if a table is bad."""
        return cls([Camera.from_dict(t, key=str(t.get("name", "")), source=source) for t in tables])
