"""BlazePose inference: the two .tflite models of the installed mediapipe wheel
(`pose_detection.tflite`, `pose_landmark_full.tflite`), run in ai-edge-litert. mediapipe itself is
never imported."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

import numpy as np

from gesturebank.errors import DetectionError
from gesturebank.extract.detectors.mediapipe import INSTALL, _quiet_startup

RUNTIME_INSTALL = "pip install ai-edge-litert==2.3.0"
DETECTOR_MODEL = Path("modules") / "pose_detection" / "pose_detection.tflite"
LANDMARK_MODEL = Path("modules") / "pose_landmark" / "pose_landmark_full.tflite"


def model_paths() -> tuple[Path, Path]:
    """(detector, landmark) .tflite files of the installed mediapipe wheel; DetectionError with
    the install command when either is missing. mediapipe itself is never imported."""
    spec = importlib.util.find_spec("mediapipe")
    if spec is None or not spec.submodule_search_locations:
        raise DetectionError(f"detector 'blazepose' needs the mediapipe wheel's models: {INSTALL}")
    root = Path(next(iter(spec.submodule_search_locations)))
    for model in (DETECTOR_MODEL, LANDMARK_MODEL):
        if not (root / model).is_file():
            raise DetectionError(
                f"{root / model}: BlazePose model missing from the installed mediapipe "
                f"(releases after 0.10.21 dropped it): {INSTALL}"
            )
    return root / DETECTOR_MODEL, root / LANDMARK_MODEL


def load_interpreter(path: Path, threads: int) -> Any:
    """An allocated ai-edge-litert Interpreter for `path`; DetectionError if the runtime is
    missing."""
    if importlib.util.find_spec("ai_edge_litert") is None:
        raise DetectionError(f"detector 'blazepose' needs the TFLite runtime: {RUNTIME_INSTALL}")
    from ai_edge_litert.interpreter import Interpreter

    with _quiet_startup():  # the XNNPACK delegate announces itself on fd 2
        interpreter = Interpreter(model_path=str(path), num_threads=threads)
        interpreter.allocate_tensors()
    return interpreter


class TfliteModel:
    """One interpreter with its input and named outputs."""

    def __init__(self, path: Path, threads: int) -> None:
        self.interpreter = load_interpreter(path, threads)
        self.input = self.interpreter.get_input_details()[0]["index"]
        self.outputs = {d["name"]: d["index"] for d in self.interpreter.get_output_details()}

    def __call__(self, tensor: np.ndarray) -> dict[str, np.ndarray]:
        """(1, n, n, 3) float32 in → every output by name, batch dimension dropped."""
        self.interpreter.set_tensor(self.input, tensor)
        self.interpreter.invoke()
        return {k: self.interpreter.get_tensor(i)[0] for k, i in self.outputs.items()}
