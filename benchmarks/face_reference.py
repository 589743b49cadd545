"""The reference face of the head pose (`extract.head_pose`): the face landmark model's mesh of
the photo the truth renderer paints on its figures (scikit-image's astronaut, `synth.looks`),
in the photo's own axes (x right, y down, z away from the camera; pixels of the 512 × 512 photo).

Prints how far the shipped `gesturebank/data/face-reference.csv` lies from a fresh measurement
(RMS, photo px); `--write` measures it again and writes the file.

    .venv/bin/python benchmarks/face_reference.py [--write] [--quick]

--quick: the same (one run of the face model).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.extract.detectors.blazepose import Roi
from gesturebank.extract.head_pose import REFERENCE_FILE, reference_face
from gesturebank.extract.mouth import CROP_PER_WIDTH, WIDTH_PER_EYES, FaceLandmarker
from gesturebank.synth.looks import PHOTO_EYE_DISTANCE_PX, PHOTO_EYES_MID, PHOTO_MOUTH, face_photo

HEADER = (
    "# The reference face of gesturebank.extract.head_pose: the 468 points (x, y, z) that the\n"
    "# face landmark model bundled with mediapipe 0.10.14 (modules/face_landmark/\n"
    "# face_landmark.tflite) gives for the face photo the truth renderer paints (scikit-image's\n"
    "# data.astronaut(): Eileen Collins, NASA, public domain), in the photo's axes: x right,\n"
    "# y down, z away from the camera, 512 x 512 photo pixels. Measured by\n"
    "# benchmarks/face_reference.py --write (one unrotated crop centred between eyes and mouth).\n"
    "# The model is mediapipe's (Apache License 2.0); the photo is in the public domain.\n"
)


def measure() -> np.ndarray:
    """(468, 3) the model's mesh of the photo, photo px."""
    photo = np.clip(face_photo() * 255 + 0.5, 0, 255).astype(np.uint8)
    side = CROP_PER_WIDTH * WIDTH_PER_EYES * PHOTO_EYE_DISTANCE_PX
    centre_y = (PHOTO_EYES_MID[1] + PHOTO_MOUTH[1]) / 2
    mesh = FaceLandmarker()(photo, Roi(PHOTO_EYES_MID[0], centre_y, side, 0.0))
    return np.asarray(mesh.points3d, np.float64)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="measure and write the file")
    parser.add_argument("--quick", action="store_true", help="the same: one model run")
    args = parser.parse_args()
    points = measure()
    path = Path(__file__).resolve().parents[1] / "gesturebank" / "data" / REFERENCE_FILE
    if args.write:
        lines = [HEADER + "x,y,z"] + [f"{x:.3f},{y:.3f},{z:.3f}" for x, y, z in points]
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        print(f"wrote {path}")
        reference_face.cache_clear()
    shipped = reference_face()
    rms = float(np.sqrt(np.mean(np.sum((shipped - points) ** 2, axis=1))))
    worst = float(np.max(np.linalg.norm(shipped - points, axis=1)))
    table = Table(title="the reference face (gesturebank/data/face-reference.csv)")
    for col in ("points", "RMS against a fresh measurement, photo px", "worst point, photo px"):
        table.add_column(col, justify="right")
    table.add_row(str(len(shipped)), f"{rms:.3f}", f"{worst:.3f}")
    Console().print(table)


if __name__ == "__main__":
    main()
