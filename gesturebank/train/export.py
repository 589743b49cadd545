"""ONNX export and onnxruntime inference for every model, including stateful one-step graphs.

Exporter: the legacy TorchScript exporter (`torch.onnx.export(..., dynamo=False)`). The dynamo
exporter needs `onnxscript`, which is not a dependency (and not installed); the TorchScript path
works offline and turns `nn.LSTM` into one ONNX `LSTM` node with explicit `initial_h`/`initial_c`
inputs and `Y_h`/`Y_c` outputs — exactly the interface a stateful step model needs.

Files:
- MLP `model.onnx`: `audio (N, F)` → `angles01 (N, 11)` (N dynamic).
- LSTM `model.onnx`: `audio (B, T, F)` → `angles01 (B, T, 11)` from a zero state (B, T dynamic).
- LSTM `model_step.onnx`: `audio (1, F)`, `h (1, 1, U)`, `c (1, 1, U)` → `angles01 (1, 11)`,
  `h_out`, `c_out`. `StreamingLSTM` carries (h, c) between 10 ms frames, so live synthesis costs
  one LSTM step per frame instead of re-running a 300-frame window (§5.1.2).
- Every other model: `model.onnx` `audio (B, T, F)` [+ its `onnx_inputs()`, e.g. the CVAE's
  `z (B, latent)`] → `angles01 (B, T, 11)`; a model with `step_module()` (Aud2Motion: state `h`)
  also gets `model_step.onnx`, inputs `audio` + its states, outputs `angles01` + `<state>_out`.

The file names and the onnxruntime session builder are the model folder's (`model_folder`).
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np
import torch

from gesturebank.errors import InputError
from gesturebank.train.contract import ExtraOnnxInputs, FrameWise, SpeechToMotion, Stateful
from gesturebank.train.model_folder import MODEL_ONNX, STEP_ONNX, session

OPSET = 17


def _export(module: torch.nn.Module, args: tuple[torch.Tensor, ...], path: Path, **kw: Any) -> None:
    module.eval()
    with warnings.catch_warnings():
        # The legacy exporter announces its deprecation and warns about LSTM internals it traces.
        warnings.simplefilter("ignore")
        torch.onnx.export(module, args, str(path), dynamo=False, opset_version=OPSET, **kw)


def export_onnx(model: torch.nn.Module, out_dir: Path) -> list[Path]:
    """Write `model.onnx` (and for stateful models `model_step.onnx`) into `out_dir`; returns
    the paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if not isinstance(model, SpeechToMotion):
        raise InputError(f"{type(model).__name__}: not a speech-to-motion model (train.contract)")
    f = int(model.n_features)
    path = out_dir / MODEL_ONNX
    if isinstance(model, FrameWise):
        _export(
            model,
            (torch.zeros(4, f),),
            path,
            input_names=["audio"],
            output_names=["angles01"],
            dynamic_axes={"audio": {0: "frames"}, "angles01": {0: "frames"}},
        )
        return [path]
    extra = model.onnx_inputs() if isinstance(model, ExtraOnnxInputs) else {}
    _export(
        model,
        (torch.zeros(1, 8, f), *(torch.zeros(shape) for shape in extra.values())),
        path,
        input_names=["audio", *extra],
        output_names=["angles01"],
        dynamic_axes={
            "audio": {0: "batch", 1: "frames"},
            "angles01": {0: "batch", 1: "frames"},
            **{name: {0: "batch"} for name in extra},
        },
    )
    if not isinstance(model, Stateful):
        return [path]
    step, state_shapes = model.step_module()
    names = ["h", "c"][: len(state_shapes)]
    step_path = out_dir / STEP_ONNX
    _export(
        step,
        (torch.zeros(1, f), *(torch.zeros(shape) for shape in state_shapes)),
        step_path,
        input_names=["audio", *names],
        output_names=["angles01", *(f"{n}_out" for n in names)],
    )
    return [path, step_path]


class OnnxModel:
    """Offline inference of `model.onnx`: z-normalised audio `(N, F)` → `(N, 11)` in [0, 1]."""

    def __init__(self, path: Path, threads: int = 1) -> None:
        self.session = session(path, threads=threads)
        inputs = self.session.get_inputs()
        self.sequence = len(inputs[0].shape) == 3  # sequence graphs take (B, T, F)
        self.z_size = next((int(i.shape[-1]) for i in inputs if i.name == "z"), 0)

    def predict(self, audio: np.ndarray, *, z_seed: int | None = None) -> np.ndarray:
        """A model with a latent z (the CVAE) decodes z = 0, or with `z_seed` a z ~ N(0, I)."""
        x = np.ascontiguousarray(audio, dtype=np.float32)
        if not self.sequence:
            return np.asarray(self.session.run(None, {"audio": x})[0])
        feed = {"audio": x[None]}
        if self.z_size:
            z = np.zeros((1, self.z_size), np.float32)
            if z_seed is not None:
                z = np.random.default_rng(z_seed).standard_normal(z.shape).astype(np.float32)
            feed["z"] = z
        return np.asarray(self.session.run(None, feed)[0][0])


class StreamingLSTM:
    """Live inference of `model_step.onnx`: one `(F,)` frame in, one `(11,)` pose out.

    The hidden state (h, c) is carried from frame to frame; `reset()` starts from zero again.
    Fed with the frames of a sequence, the outputs equal `OnnxModel.predict` of the whole
    sequence.
    """

    def __init__(self, path: Path, threads: int = 1) -> None:
        self.session = session(path, threads=threads)
        inputs = {i.name: i.shape for i in self.session.get_inputs()}
        if set(inputs) != {"audio", "h", "c"}:
            raise InputError(f"{path}: not a stateful LSTM step model (inputs {sorted(inputs)})")
        self.units = int(inputs["h"][-1])
        self.n_features = int(inputs["audio"][-1])
        self.reset()

    def reset(self) -> None:
        self.h = np.zeros((1, 1, self.units), np.float32)
        self.c = np.zeros((1, 1, self.units), np.float32)

    def step(self, frame: np.ndarray) -> np.ndarray:
        x = np.asarray(frame, dtype=np.float32).reshape(1, self.n_features)
        y, self.h, self.c = self.session.run(None, {"audio": x, "h": self.h, "c": self.c})
        return np.asarray(y[0])

    def run(self, audio: np.ndarray) -> np.ndarray:
        """Step through `audio (N, F)` from the current state; `(N, 11)`."""
        return np.stack([self.step(row) for row in np.asarray(audio)])
