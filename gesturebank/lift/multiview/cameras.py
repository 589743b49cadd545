"""Calibrated pinhole cameras (OpenCV model) and camera groups, with TOML and Qualisys I/O.

A `Camera` maps world points to pixels: `x_cam = R @ X + t`, pinhole `K`, and OpenCV's radial /
tangential distortion `(k1, k2, p1, p2[, k3])`. World units are metres. A `CameraGroup` is the
ordered set of cameras of one take; arrays over it carry the camera axis first, `(C, ...)`.

The TOML layout is the one Pose2Sim and anipose write: one table per camera with `name`,
`size = [w, h]`, `matrix` (3x3), `distortions`, `rotation` (Rodrigues vector, world → camera),
`translation` (metres) and `fisheye`, plus an optional `[metadata]` table.
"""

from __future__ import annotations

import logging
import os
import tomllib
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import tomli_w
from scipy.spatial.transform import Rotation

from gesturebank.errors import CalibrationError

log = logging.getLogger(__name__)

PathLike = str | os.PathLike[str]

# Qualisys stores focal length and principal point in sub-pixel units of 1/64 pixel.
_QCA_SUBPIXEL = 64.0
# Qualisys' camera frame has y and z flipped with respect to OpenCV's.
_QCA_TO_OPENCV = np.diag([1.0, -1.0, -1.0])


# scipy rather than cv2.Rodrigues: OpenCV returns a zero vector for rotations under 1e-5 rad,
# so a nearly aligned camera would not survive a save/load round trip.
def _rodrigues_to_matrix(rvec: np.ndarray) -> np.ndarray:
    return Rotation.from_rotvec(np.asarray(rvec, np.float64).reshape(3)).as_matrix()


def _matrix_to_rodrigues(rotation: np.ndarray) -> np.ndarray:
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
            R = _rodrigues_to_matrix(R)
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
        return _matrix_to_rodrigues(self.R)

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

    def subset(self, names: Sequence[str]) -> CameraGroup:
        """The cameras called `names`, in that order."""
        by_name = {c.name: c for c in self.cameras}
        unknown = [n for n in names if n not in by_name]
        if unknown:
            raise CalibrationError(f"unknown cameras {unknown}; have {self.names}")
        return CameraGroup([by_name[n] for n in names])

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

    # ----------------------------------------------------------------- I/O

    def to_toml(self) -> str:
        tables: dict[str, Any] = {}
        for cam in self.cameras:
            tables[cam.name] = cam.to_dict()
        tables["metadata"] = {"adjusted": False, "error": 0.0}
        return tomli_w.dumps(tables)

    def save(self, path: PathLike) -> None:
        """Write the group as a Pose2Sim/anipose calibration TOML."""
        Path(path).write_text(self.to_toml(), encoding="utf-8")

    @classmethod
    def from_toml(cls, path: PathLike) -> CameraGroup:
        """Read a Pose2Sim/anipose calibration TOML (tables with a `matrix` are cameras)."""
        name = os.fspath(path)
        try:
            data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise CalibrationError(f"{name}: calibration file not found") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise CalibrationError(f"{name}: cannot read calibration file ({exc})") from None
        except tomllib.TOMLDecodeError as exc:
            raise CalibrationError(f"{name}: not valid TOML ({exc})") from None
        cams = [
            Camera.from_dict(table, key=key, source=name)
            for key, table in data.items()
            if isinstance(table, dict) and key != "metadata"
        ]
        if not cams:
            raise CalibrationError(f"{name}: no camera tables (with size/matrix/rotation)")
        return cls(cams)

    @classmethod
    def from_qca(cls, path: PathLike) -> CameraGroup:
        """Read a Qualisys `.qca.txt` XML calibration (positions in mm → metres)."""
        name = os.fspath(path)
        try:
            root = ET.parse(name).getroot()
        except FileNotFoundError:
            raise CalibrationError(f"{name}: calibration file not found") from None
        except (OSError, ET.ParseError) as exc:
            raise CalibrationError(f"{name}: not a readable Qualisys XML file ({exc})") from None
        cams = [_qca_camera(node, name) for node in root.iter("camera")]
        if not cams:
            raise CalibrationError(f"{name}: no <camera> elements")
        return cls(cams)

    @classmethod
    def load(cls, path: PathLike) -> CameraGroup:
        """A calibration file by its name: `*.toml` or Qualisys `*.qca.txt`."""
        lower = os.fspath(path).lower()
        if lower.endswith(".toml"):
            return cls.from_toml(path)
        if lower.endswith((".qca.txt", ".qca")):
            return cls.from_qca(path)
        raise CalibrationError(f"{os.fspath(path)}: unknown calibration format (.toml, .qca.txt)")


def _qca_camera(node: ET.Element, source: str) -> Camera:
    serial = node.get("serial", "?")
    where = f"{source}: camera {serial!r}"
    transform, intrinsic, fov = (
        node.find("transform"),
        node.find("intrinsic"),
        node.find("fov_video"),
    )
    if transform is None or intrinsic is None or fov is None:
        raise CalibrationError(f"{where}: needs <transform>, <intrinsic> and <fov_video>")
    try:
        R_qca = np.array([[float(transform.get(f"r{i}{j}", "")) for j in "123"] for i in "123"])
        center = np.array([float(transform.get(k, "")) for k in "xyz"]) / 1000.0  # mm → m
        left, top = float(fov.get("left", "")), float(fov.get("top", ""))
        right, bottom = float(fov.get("right", "")), float(fov.get("bottom", ""))
        f_u, f_v, c_u, c_v = (
            float(intrinsic.get(k, "")) / _QCA_SUBPIXEL
            for k in ("focalLengthU", "focalLengthV", "centerPointU", "centerPointV")
        )
        dist = np.array(
            [
                float(intrinsic.get(k, ""))
                for k in (
                    "radialDistortion1",
                    "radialDistortion2",
                    "tangentalDistortion1",
                    "tangentalDistortion2",
                    "radialDistortion3",
                )
            ]
        )
    except ValueError:
        raise CalibrationError(f"{where}: missing or non-numeric calibration values") from None
    R = _QCA_TO_OPENCV @ R_qca
    # The principal point is given on the sensor; the video window starts at (left, top).
    K = np.array([[f_u, 0.0, c_u - left], [0.0, f_v, c_v - top], [0.0, 0.0, 1.0]])
    try:
        return Camera(
            name=serial,
            size=(int(right - left + 1), int(bottom - top + 1)),
            K=K,
            dist=dist,
            R=R,
            t=-R @ center,
        )
    except CalibrationError as exc:
        raise CalibrationError(f"{where}: {exc}") from None
