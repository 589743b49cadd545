"""Intrinsic calibration: the Pose2Sim demo's real checkerboard photos, a rendered ChArUco
board, and the errors users meet ("0 boards")."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import cv2
import numpy as np
import pytest
from pydantic import ValidationError

from gesturebank.config import BoardConfig
from gesturebank.errors import CalibrationError
from gesturebank.lift.multiview.calibrate import calibrate_intrinsics

DEMO = "pose2sim/Demo_SinglePerson/calibration"


def qca_focals(path: Path) -> dict[str, float]:
    """Focal length (px) per camera straight from the Qualisys XML (1/64 px units)."""
    out = {}
    for node in ET.parse(path).getroot().iter("camera"):
        intr = node.find("intrinsic")
        assert intr is not None
        fu = float(intr.get("focalLengthU", "nan"))
        fv = float(intr.get("focalLengthV", "nan"))
        out[str(node.get("serial"))] = (fu + fv) / 2 / 64
    return out


def test_demo_checkerboards_match_qualisys_focal(samples: Path) -> None:
    reference = qca_focals(samples / DEMO / "Calib.qca.txt")
    board = BoardConfig(kind="checkerboard", inner_corners=(4, 7), square_size=0.06)
    print("\ncamera  boards  rejected  rms px  focal px  QCA px   diff")
    for cam, f_ref in reference.items():
        result = calibrate_intrinsics(samples / DEMO / f"intrinsics/int_{cam}_img", board)
        diff = result.focal / f_ref - 1
        print(
            f"{cam}   {len(result.per_image) + len(result.rejected)}/"
            f"{len(result.per_image) + len(result.rejected) + len(result.missing)}"
            f"     {list(result.rejected) or '-'}  {result.rms:5.2f}   {result.focal:7.1f}  "
            f"{f_ref:7.1f}  {diff:+.2%}"
        )
        assert abs(diff) < 0.03, f"{cam}: focal {result.focal:.1f} vs QCA {f_ref:.1f}"
        assert len(result.per_image) >= 5
        assert result.size == (1088, 1920)
        # The board corners are sharp: every photo kept reprojects within a pixel.
        assert max(result.per_image.values()) < 1.0
        assert abs(result.K[0, 2] - 544) < 60 and abs(result.K[1, 2] - 960) < 60


def render_charuco(tmp_path: Path, K: np.ndarray, size: tuple[int, int]) -> list[Path]:
    """Photos of a 7x5 ChArUco board (4 cm squares) seen by camera K from 8 known poses."""
    board = cv2.aruco.CharucoBoard(
        (7, 5), 0.04, 0.03, cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    )
    px_per_m, margin = 2500.0, 40
    flat = board.generateImage((700 + 2 * margin, 500 + 2 * margin), marginSize=margin)
    # Board image pixel (u, v) ↔ board plane point ((u − margin) / s, (v − margin) / s, 0).
    to_plane = np.array(
        [[1 / px_per_m, 0, -margin / px_per_m], [0, 1 / px_per_m, -margin / px_per_m], [0, 0, 1]]
    )
    paths = []
    rng = np.random.default_rng(7)
    for i in range(8):
        rvec = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-0.3, 0.3)])
        R = cv2.Rodrigues(rvec)[0]
        center = np.array([0.14, 0.10, 0.0])  # board centre in its own plane
        t = np.array([rng.uniform(-0.08, 0.08), rng.uniform(-0.06, 0.06), rng.uniform(0.55, 0.8)])
        t = t - R @ center
        H = K @ np.column_stack([R[:, 0], R[:, 1], t]) @ to_plane
        img = cv2.warpPerspective(flat, H, size, flags=cv2.INTER_AREA, borderValue=(110,))
        path = tmp_path / f"charuco_{i:02d}.png"
        cv2.imwrite(str(path), img)
        paths.append(path)
    return paths


def test_charuco_board_recovers_known_intrinsics(tmp_path: Path) -> None:
    K = np.array([[1100.0, 0, 650], [0, 1100.0, 470], [0, 0, 1]])
    paths = render_charuco(tmp_path, K, (1280, 960))
    board = BoardConfig(kind="charuco", squares=(7, 5), square_size=0.04, marker_size=0.03)
    result = calibrate_intrinsics(paths, board)
    assert len(result.per_image) >= 6
    assert result.focal == pytest.approx(1100.0, rel=0.01)
    assert result.K[0, 2] == pytest.approx(650, abs=10)
    assert result.K[1, 2] == pytest.approx(470, abs=10)
    assert result.rms < 1.0


def test_zero_boards_names_the_images_and_the_likely_cause(samples: Path) -> None:
    folder = samples / DEMO / "intrinsics/int_cam01_img"
    # The classic mistake: counting squares (5x8) instead of inner corners (4x7).
    with pytest.raises(CalibrationError) as info:
        calibrate_intrinsics(folder, BoardConfig(inner_corners=(5, 8)))
    msg = str(info.value)
    assert "\n" not in msg
    assert str(folder) in msg and "found in 0 of 7" in msg
    assert "cam01_01_int.jpg" in msg and "inner corners" in msg


def test_charuco_not_found_in_checkerboard_photos(samples: Path) -> None:
    paths = sorted((samples / DEMO / "intrinsics/int_cam02_img").glob("*.jpg"))[:3]
    with pytest.raises(CalibrationError, match=r"ChArUco board .* found in 0 of 3"):
        calibrate_intrinsics(paths, BoardConfig(kind="charuco"))


def test_bad_image_inputs(tmp_path: Path) -> None:
    with pytest.raises(CalibrationError, match="no such folder"):
        calibrate_intrinsics(tmp_path / "missing")
    with pytest.raises(CalibrationError, match="no images"):
        calibrate_intrinsics(tmp_path)
    bad = tmp_path / "broken.jpg"
    bad.write_bytes(b"not a jpeg")
    with pytest.raises(CalibrationError, match=r"broken.jpg: not a readable image"):
        calibrate_intrinsics(tmp_path)
    bad.unlink()
    cv2.imwrite(str(tmp_path / "a.png"), np.zeros((20, 30), np.uint8))
    cv2.imwrite(str(tmp_path / "b.png"), np.zeros((30, 20), np.uint8))
    with pytest.raises(CalibrationError, match=r"b.png: image is 20x30"):
        calibrate_intrinsics(tmp_path)


def test_board_config_validation() -> None:
    with pytest.raises(ValidationError, match="marker_size"):
        BoardConfig(kind="charuco", square_size=0.03, marker_size=0.04)
    with pytest.raises(ValidationError, match="dictionary"):
        BoardConfig(kind="charuco", dictionary="DICT_NOPE")
    with pytest.raises(ValidationError):
        BoardConfig(inner_corners=(1, 7))
    with pytest.raises(ValidationError):
        BoardConfig(square_size=0)


def test_calibrate_command_writes_the_toml_multiview_reads(samples: Path, tmp_path: Path) -> None:
    import shutil
    import subprocess
    import sys

    from gesturebank.camera_files import read_qca, read_toml

    photos = tmp_path / "intrinsics"
    for cam in ("cam01", "cam03"):  # two of the four cameras keep the test short
        shutil.copytree(samples / DEMO / f"intrinsics/int_{cam}_img", photos / f"int_{cam}_img")
    qca = samples / DEMO / "Calib.qca.txt"
    out = tmp_path / "calib.toml"
    cmd = [str(Path(sys.executable).parent / "gesturebank"), "calibrate", str(photos)]
    cmd += ["--placement", str(qca), "--out", str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    assert r.returncode == 0, r.stderr
    group = read_toml(out)
    placed = read_qca(qca)
    assert group.names == ["cam01", "cam03"]
    for cam in group:
        ref = placed.subset([cam.name])[0]
        np.testing.assert_allclose(cam.R, ref.R, atol=1e-9)
        np.testing.assert_allclose(cam.t, ref.t, atol=1e-12)
        assert cam.size == (1088, 1920)
        assert (cam.K[0, 0] + cam.K[1, 1]) / 2 == pytest.approx(qca_focals(qca)[cam.name], rel=0.03)
    assert "cam03: board in" in r.stdout

    # Squares counted instead of inner corners: one line, exit 2, nothing written.
    bad = tmp_path / "bad.toml"
    r = subprocess.run(
        [*cmd[:-1], str(bad), "--inner-corners", "5", "8"],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "found in 0 of 7" in r.stderr
    assert not bad.exists()

    # The board is the [board] section: --set reaches it, a bad value is one line, exit 2.
    r = subprocess.run(
        [*cmd[:-1], str(bad), "--set", "board.kind=charuco", "--set", "board.marker_size=0.1"],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "board: " in r.stderr and "marker_size" in r.stderr
    assert not bad.exists()
