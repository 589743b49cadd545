"""Intrinsic calibration from photos of a checkerboard or a ChArUco board (OpenCV 5).

`calibrate_intrinsics(images, board)` finds the board in each photo, runs `cv2.calibrateCamera`
and reports the RMS and per-image reprojection error. When no photo shows the board (the usual
"0 boards found"), the CalibrationError names the photos and the board it looked for, because
the cause is nearly always a board description that does not match the print: a checkerboard is
described by its *inner* corners (squares − 1 in each direction), a ChArUco board by its squares.
`calibrate_group` does it for every camera of a rig (`gesturebank calibrate`).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from gesturebank.camera_files import Camera, CameraGroup
from gesturebank.config import BoardConfig
from gesturebank.errors import CalibrationError

log = logging.getLogger(__name__)

PathLike = str | os.PathLike[str]
IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff")


@dataclass(frozen=True)
class Intrinsics:
    """Result of one camera's intrinsic calibration.

    K (3, 3); dist (5,) = k1, k2, p1, p2, k3; size (width, height) px; rms px (OpenCV's);
    per_image: RMS reprojection error (px) of each photo used, by file name;
    missing: photos without a detected board;
    rejected: photos whose board was found but reprojected worse than `max_image_error_px` in
    a first fit (a misdetected corner order, motion blur), with that error; left out of the fit.
    """

    K: np.ndarray
    dist: np.ndarray
    size: tuple[int, int]
    rms: float
    per_image: dict[str, float]
    missing: tuple[str, ...]
    rejected: dict[str, float]

    @property
    def focal(self) -> float:
        """Mean of fx and fy, px."""
        return float((self.K[0, 0] + self.K[1, 1]) / 2)


def _charuco(board: BoardConfig) -> cv2.aruco.CharucoBoard:
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, board.dictionary))
    cb = cv2.aruco.CharucoBoard(board.squares, board.square_size, board.marker_size, dictionary)
    cb.setLegacyPattern(board.legacy_pattern)
    return cb


class BoardDetector:
    """Finds one board in grey images → (object points (N, 3) m, image points (N, 2) px)."""

    def __init__(self, board: BoardConfig) -> None:
        self.board = board
        if board.kind == "charuco":
            self._charuco = _charuco(board)
            self._detector = cv2.aruco.CharucoDetector(self._charuco)
        else:
            x, y = board.inner_corners
            grid = np.mgrid[0:x, 0:y].T.reshape(-1, 2)
            self._object = np.hstack([grid, np.zeros((len(grid), 1))]) * board.square_size

    def detect(self, grey: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """None when the board is not found (or too little of it, for ChArUco)."""
        if self.board.kind == "charuco":
            corners, ids, _, _ = self._detector.detectBoard(grey)
            if ids is None or len(ids) < self.board.min_corners:
                return None
            obj, img = self._charuco.matchImagePoints(corners, ids)  # type: ignore[call-overload]
            return np.asarray(obj, np.float64).reshape(-1, 3), np.asarray(img).reshape(-1, 2)
        pattern = self.board.inner_corners
        flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
        found, corners = cv2.findChessboardCorners(grey, pattern, flags=flags)
        if not found:
            # The sector-based detector copes with blur and uneven light the classic one misses.
            found, corners = cv2.findChessboardCornersSB(grey, pattern)
            if not found:
                return None
        else:
            criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)
            corners = cv2.cornerSubPix(grey, corners, (11, 11), (-1, -1), criteria)
        return self._object.copy(), np.asarray(corners, np.float64).reshape(-1, 2)


def _read_grey(path: Path) -> np.ndarray:
    grey = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if grey is None:
        raise CalibrationError(f"{path}: not a readable image")
    return grey


def image_files(folder: PathLike) -> list[Path]:
    """The calibration photos in `folder`, sorted; CalibrationError if there are none."""
    root = Path(folder)
    if not root.is_dir():
        raise CalibrationError(f"{root}: no such folder of calibration images")
    files = sorted(p for p in root.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise CalibrationError(f"{root}: no images ({', '.join(IMAGE_SUFFIXES)})")
    return files


def _names(paths: Sequence[Path], limit: int = 6) -> str:
    shown = ", ".join(p.name for p in paths[:limit])
    return shown + (f", … ({len(paths)} in all)" if len(paths) > limit else "")


def calibrate_intrinsics(
    images: Sequence[PathLike] | PathLike,
    board: BoardConfig | None = None,
    *,
    min_views: int = 3,
    max_image_error_px: float | None = 1.0,
) -> Intrinsics:
    """Calibrate K and (k1, k2, p1, p2, k3) from photos of `board`.

    images: photo paths, or a folder holding them. min_views: fewest photos with a board.
    max_image_error_px: photos reprojecting worse than this (RMS px) in a first fit are left
    out and the fit repeated, as long as `min_views` remain (None keeps every photo).
    Raises CalibrationError naming the photos when fewer than `min_views` show the board.
    """
    board = board or BoardConfig()
    if isinstance(images, str | os.PathLike):
        paths = image_files(images)
    else:
        paths = [Path(p) for p in images]
    if not paths:
        raise CalibrationError("calibrate_intrinsics: no images given")
    detector = BoardDetector(board)
    size: tuple[int, int] | None = None
    obj_pts: list[np.ndarray] = []
    img_pts: list[np.ndarray] = []
    found: list[Path] = []
    missing: list[Path] = []
    for path in paths:
        grey = _read_grey(path)
        shape = (grey.shape[1], grey.shape[0])
        if size is None:
            size = shape
        elif shape != size:
            raise CalibrationError(f"{path}: image is {shape[0]}x{shape[1]}, others {size}")
        hit = detector.detect(grey)
        if hit is None:
            missing.append(path)
            continue
        obj_pts.append(hit[0].astype(np.float32))
        img_pts.append(hit[1].astype(np.float32))
        found.append(path)
    log.info("board found in %d of %d images", len(found), len(paths))
    if len(found) < min_views:
        hint = (
            " (count inner corners: squares − 1 in each direction)"
            if board.kind == "checkerboard"
            else " (check squares, dictionary and legacy_pattern)"
        )
        where = paths[0].parent
        raise CalibrationError(
            f"{where}: {board.describe()} found in {len(found)} of {len(paths)} images, need "
            f"{min_views}; not found in {_names(missing)}{hint}"
        )
    assert size is not None
    rms, K, dist, per_image = _fit(found, obj_pts, img_pts, size)
    rejected: dict[str, float] = {}
    if max_image_error_px is not None:
        bad = {n: e for n, e in per_image.items() if e > max_image_error_px}
        if bad and len(per_image) - len(bad) >= min_views:
            log.info(
                "calibration: leaving out %s (reprojection error > %.2f px)",
                ", ".join(bad),
                max_image_error_px,
            )
            keep = [i for i, p in enumerate(found) if p.name not in bad]
            rms, K, dist, per_image = _fit(
                [found[i] for i in keep],
                [obj_pts[i] for i in keep],
                [img_pts[i] for i in keep],
                size,
            )
            rejected = bad
    return Intrinsics(
        K=K,
        dist=dist,
        size=size,
        rms=rms,
        per_image=per_image,
        missing=tuple(p.name for p in missing),
        rejected=rejected,
    )


def _fit(
    paths: list[Path],
    obj_pts: list[np.ndarray],
    img_pts: list[np.ndarray],
    size: tuple[int, int],
) -> tuple[float, np.ndarray, np.ndarray, dict[str, float]]:
    """cv2.calibrateCamera → (rms, K (3, 3), dist (5,), RMS error per image by name)."""
    rms, K, dist, rvecs, tvecs = cv2.calibrateCamera(obj_pts, img_pts, size, None, None)
    per_image: dict[str, float] = {}
    for path, obj, img, rvec, tvec in zip(paths, obj_pts, img_pts, rvecs, tvecs, strict=True):
        proj, _ = cv2.projectPoints(obj, rvec, tvec, K, dist)
        err = np.linalg.norm(proj.reshape(-1, 2) - img.reshape(-1, 2), axis=1)
        per_image[path.name] = float(np.sqrt(np.mean(err**2)))
    K = np.asarray(K, np.float64)
    return float(rms), K, np.asarray(dist, np.float64).ravel()[:5], per_image


def camera_folders(root: PathLike) -> dict[str, Path]:
    """The photo sub-folders of `root` by camera name, sorted.

    Pose2Sim's layout names them `int_<camera>_img`; the affixes are dropped so that the name
    matches the camera's video stem (`int_cam01_img` → `cam01`). Other folders keep their name.
    """
    top = Path(root)
    if not top.is_dir():
        raise CalibrationError(f"{top}: no such folder of calibration photos")
    folders: dict[str, Path] = {}
    for sub in sorted(p for p in top.iterdir() if p.is_dir()):
        name = sub.name.removeprefix("int_").removesuffix("_img")
        if any(p.suffix.lower() in IMAGE_SUFFIXES for p in sub.iterdir()):
            folders[name] = sub
    if not folders:
        raise CalibrationError(f"{top}: no sub-folders of photos (one per camera)")
    return folders


def calibrate_group(
    *, photos: PathLike, placement: CameraGroup, board: BoardConfig
) -> tuple[CameraGroup, dict[str, Intrinsics]]:
    """Each camera's intrinsics from its folder of board photos, placed as in `placement`.

    photos: one sub-folder per camera (`camera_folders`); placement: a calibration whose
    rotation and translation of each camera are kept (its intrinsics are replaced).
    Returns the new group and each camera's calibration report.
    """
    folders = camera_folders(photos)
    unknown = [n for n in folders if n not in placement.names]
    if unknown:
        raise CalibrationError(
            f"{photos}: cameras {unknown} are not in the placement calibration ({placement.names})"
        )
    reports = {name: calibrate_intrinsics(folder, board) for name, folder in folders.items()}
    poses = {cam.name: cam for cam in placement}
    cameras = [
        Camera(name=name, size=r.size, K=r.K, dist=r.dist, R=poses[name].R, t=poses[name].t)
        for name, r in reports.items()
    ]
    return CameraGroup(cameras), reports
