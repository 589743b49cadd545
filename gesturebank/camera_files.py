"""Calibration files: camera groups read from and written to Pose2Sim/anipose TOML and Qualisys.

The cameras themselves (`Camera`, the pinhole model, and `CameraGroup`) live in
`gesturebank.geometry`; they are re-exported here, where they were first defined. This module
reads a group from a file (`load_cameras`, `read_toml`, `read_qca`) and writes one
(`save_cameras`, `cameras_toml`).

The TOML layout is the one Pose2Sim and anipose write: one table per camera with `name`,
`size = [w, h]`, `matrix` (3x3), `distortions`, `rotation` (Rodrigues vector, world → camera),
`translation` (metres) and `fisheye`, plus an optional `[metadata]` table.
"""

from __future__ import annotations

import logging
import os
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from gesturebank.errors import CalibrationError
from gesturebank.geometry import Camera, CameraGroup

__all__ = [
    "Camera",
    "CameraGroup",
    "cameras_toml",
    "load_cameras",
    "read_qca",
    "read_toml",
    "save_cameras",
]

log = logging.getLogger(__name__)

PathLike = str | os.PathLike[str]

# Qualisys stores focal length and principal point in sub-pixel units of 1/64 pixel.
_QCA_SUBPIXEL = 64.0
# Qualisys' camera frame has y and z flipped with respect to OpenCV's.
_QCA_TO_OPENCV = np.diag([1.0, -1.0, -1.0])


def cameras_toml(group: CameraGroup) -> str:
    """The group as a Pose2Sim/anipose calibration TOML."""
    tables: dict[str, Any] = {}
    for cam in group.cameras:
        tables[cam.name] = cam.to_dict()
    tables["metadata"] = {"adjusted": False, "error": 0.0}
    return tomli_w.dumps(tables)


def save_cameras(group: CameraGroup, path: PathLike) -> None:
    """Write the group as a Pose2Sim/anipose calibration TOML."""
    Path(path).write_text(cameras_toml(group), encoding="utf-8")


def read_toml(path: PathLike) -> CameraGroup:
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
    return CameraGroup(cams)


def read_qca(path: PathLike) -> CameraGroup:
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
    return CameraGroup(cams)


def load_cameras(path: PathLike) -> CameraGroup:
    """A calibration file by its name: `*.toml` or Qualisys `*.qca.txt`."""
    lower = os.fspath(path).lower()
    if lower.endswith(".toml"):
        return read_toml(path)
    if lower.endswith((".qca.txt", ".qca")):
        return read_qca(path)
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
