"""The trained-model folder on disk (as `datasets.store` is the dataset): names, write, load, ONNX.

    weights.pt         state dict (read with torch.load(weights_only=True))
    model.json         architecture, whether the model is causal (live mode needs it), its target
                       ("speaker" or "listener": live and evaluate check it), variant and
                       split, resolved TrainConfig, audio config, frame rate, training history
    normalisers.json   audio z-norm stats per subject and "*" (dataset.json), angle limits, robot
                       profile, joint names, the training mean pose (normalised) for the baseline
    model.onnx         offline inference graph; model_step.onnx for stateful causal models
                       (LSTM, Aud2Motion: one frame + state); both written by `export.export_onnx`
    loss.png           training and validation loss per epoch (`loss_plot`)
    metrics.json       written by `evaluate`

Live mode needs only an ONNX graph, model.json's "audio" and normalisers.json's
"audio_znorm_by_subject" and "robot_profile"; `load` asks for no more, and `OnnxFrameModel` steps
the graph one frame at a time. Torch and onnxruntime are imported only when used, so live mode
does not pull in torch.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError

from gesturebank import __version__
from gesturebank.clip import parts_label
from gesturebank.config import AudioConfig, TrainConfig
from gesturebank.errors import InputError
from gesturebank.fileio import atomic_folder, output_errors, write_bytes_atomic
from gesturebank.robot import pepper
from gesturebank.train.contract import SpeechToMotion

if TYPE_CHECKING:
    import onnxruntime as ort
    from torch import nn

    from gesturebank.datasets.store import Dataset
    from gesturebank.train.trainer import TrainResult

PathLike = str | os.PathLike[str]
WEIGHTS = "weights.pt"
MODEL_JSON = "model.json"
NORMALISERS = "normalisers.json"
METRICS = "metrics.json"
LOSS_PNG = "loss.png"
MODEL_ONNX = "model.onnx"
STEP_ONNX = "model_step.onnx"


# --------------------------------------------------------------------------------------------------
# model.json


class TrainingRecord(BaseModel):
    """model.json's "result": how training went (`trainer.TrainResult`)."""

    model_config = ConfigDict(extra="allow")

    best_epoch: int
    best_val_loss: float
    epochs: int
    max_epochs: int | None = None  # folders from before `train --epochs` do not say
    stopped: str | None = None
    seconds: float
    history: list[dict[str, Any]]  # epoch, train_loss, val_loss, lr [, stage]


class ModelInfo(BaseModel):
    """model.json, in the order it is written. Only "audio" is required: live mode needs no more,
    and folders written for it (or by older versions) may hold only that; the rest is None then.
    Unknown keys are kept."""

    model_config = ConfigDict(extra="allow")

    tool_version: str | None = None
    architecture: dict[str, Any] | None = None  # `models.build.architecture`: kind, sizes
    causal: bool = True  # folders from before the key held MLP or LSTM models, both causal
    variant: str | None = None  # "si" | "sd" | "dyadic"
    target: str = "speaker"  # what it predicts (`config.Target`); folders before it: speaker
    fold: int | None = None
    subject: str | None = None
    dataset: str | None = None  # the dataset folder it was trained on
    train_config: dict[str, Any] | None = None  # the resolved TrainConfig
    audio: AudioConfig
    rate_hz: float | None = None  # pose frames per second
    reach: str | None = None  # the angles' reach mode (older folders do not say)
    require: str | None = None  # body parts every clip it was trained on had (None: any)
    result: TrainingRecord | None = None

    def need(self, folder: Path, key: str) -> Any:
        """The value of `key`; InputError (one line) when this model.json does not have it."""
        value = getattr(self, key)
        if value is None:
            raise InputError(f"{folder / MODEL_JSON}: no {key!r} (a folder written by `train`?)")
        return value


# --------------------------------------------------------------------------------------------------
# Writing


def check_target(out: Path) -> None:
    """Refuse an --out that training would wipe although it holds something else."""
    if out.exists() and (
        not out.is_dir() or (any(out.iterdir()) and not (out / MODEL_JSON).is_file())
    ):
        raise InputError(f"{out}: exists and is not a model folder (no {MODEL_JSON}); choose --out")


@contextmanager
def writing(out: PathLike) -> Iterator[Path]:
    """A temporary folder to fill, swapped in whole for `out` when the block succeeds: no file
    of an older model survives, a failed or interrupted run keeps the old one. The folder is
    made on entry, so an unwritable `out` fails at once (InputError naming it)."""
    with output_errors(out, "the model folder"), atomic_folder(out) as tmp:
        yield tmp


def _write_json(path: Path, data: Any) -> None:
    write_bytes_atomic(path, json.dumps(data, indent=1, allow_nan=True).encode())


def write(
    folder: Path,
    *,
    net: nn.Module,
    dataset: Dataset,
    variant: str,
    fold: int | None,
    subject: str | None,
    config: TrainConfig,
    result: TrainResult,
    mean_pose01: np.ndarray,
) -> None:
    """weights.pt, model.json and normalisers.json of a trained `net` into `folder` (one from
    `writing`; the ONNX graphs go there too, through `export.export_onnx`)."""
    import torch

    from gesturebank.robot.timeline import reach_of
    from gesturebank.train.models.build import architecture

    torch.save(net.state_dict(), folder / WEIGHTS)
    info = ModelInfo(
        tool_version=__version__,
        architecture=architecture(net),
        causal=bool(net.causal) if isinstance(net, SpeechToMotion) else False,
        variant=variant,
        target=config.target,
        fold=fold,
        subject=subject,
        dataset=str(dataset.path.resolve()),
        train_config=config.model_dump(mode="json"),
        audio=dataset.info.config.audio,
        rate_hz=dataset.info.rates.pose_hz,
        reach=reach_of(dataset.info.config),  # the angles' reach mode, for synthesize
        require=parts_label(dataset.require) if dataset.require else None,
        result=TrainingRecord(
            best_epoch=result.best_epoch,
            best_val_loss=result.best_val_loss,
            epochs=result.epochs,
            max_epochs=result.max_epochs,
            stopped=result.stopped,
            seconds=result.seconds,
            history=result.history,
        ),
    )
    # python mode: json.dumps writes floats (inf, nan too) as before; "audio" in JSON mode
    _write_json(
        folder / MODEL_JSON, {**info.model_dump(), "audio": info.audio.model_dump(mode="json")}
    )
    _write_json(
        folder / NORMALISERS,
        {
            "audio_znorm_by_subject": {
                k: v.model_dump() for k, v in dataset.info.audio_znorm_by_subject.items()
            },
            "limits": dataset.info.limits,
            "robot_profile": dataset.info.robot_profile,
            "joints": list(pepper.JOINTS),
            "mean_pose01": np.asarray(mean_pose01).tolist(),
        },
    )


def write_metrics(folder: PathLike, report: dict[str, Any]) -> None:
    """metrics.json (what `evaluate` measured) into the model folder."""
    path = Path(folder) / METRICS
    with output_errors(path, "the metrics"):
        _write_json(path, report)


# --------------------------------------------------------------------------------------------------
# Reading


@dataclass(frozen=True, eq=False)
class ModelFolder:
    """A model folder read by `load`: model.json (`info`), normalisers.json (`norm`), and the
    audio config and robot profile (limits the angles are normalised to) they give."""

    path: Path
    info: ModelInfo
    norm: dict[str, Any]
    audio: AudioConfig
    profile: pepper.RobotProfile

    @property
    def graph(self) -> Path:
        """The graph for one frame at a time: model_step.onnx if there is one, else model.onnx."""
        return _graph(self.path)

    @property
    def causal(self) -> bool:
        """Whether each output frame depends on past audio only (folders from before the key
        held MLP or LSTM models, both causal)."""
        return self.info.causal

    @property
    def train_config(self) -> TrainConfig:
        return TrainConfig.model_validate(self.info.need(self.path, "train_config"))

    def file(self, name: str) -> Path:
        """The folder's file `name`; InputError (one line) when it is missing."""
        return _require(self.path / name, self.path)

    def znorm(self, who: str) -> tuple[np.ndarray, np.ndarray]:
        """Audio z-norm (mean `(F,)`, std `(F,)`) of subject `who`, or "*" for the whole dataset."""
        stats = self.norm["audio_znorm_by_subject"]
        if who not in stats:
            known = ", ".join(sorted(stats))
            raise InputError(f"{self.path}: no audio statistics for {who!r}; have {known}")
        return np.asarray(stats[who]["mean"], np.float64), np.asarray(stats[who]["std"], np.float64)

    def torch_model(self) -> nn.Module:
        """The torch model with its trained weights, in eval mode."""
        import torch

        from gesturebank.train.models.build import from_architecture

        net = from_architecture(self.info.need(self.path, "architecture"))
        net.load_state_dict(torch.load(self.file(WEIGHTS), weights_only=True))
        net.eval()
        return net


def _graph(folder: Path) -> Path:
    return folder / STEP_ONNX if (folder / STEP_ONNX).is_file() else folder / MODEL_ONNX


def _require(path: Path, folder: Path) -> Path:
    if not path.is_file():
        raise InputError(f"{path}: missing — is {folder} a model folder written by `train`?")
    return path


def load(model_dir: PathLike) -> ModelFolder:
    """The model folder `model_dir`, checked: an ONNX graph, model.json and normalisers.json
    readable, with the audio config, z-norm stats and robot profile. InputError (one line)
    naming what is missing or unreadable."""
    folder = Path(model_dir)
    for path in (_graph(folder), folder / MODEL_JSON, folder / NORMALISERS):
        _require(path, folder)
    try:
        info = ModelInfo.model_validate(json.loads((folder / MODEL_JSON).read_text("utf-8")))
        norm = json.loads((folder / NORMALISERS).read_text(encoding="utf-8"))
        audio = info.audio
        if not isinstance(norm["audio_znorm_by_subject"], dict):
            raise TypeError("audio_znorm_by_subject is not a table")
        name = str(norm["robot_profile"])
        limits = norm.get("limits")
        stored = _stored_profile(limits, name) if limits else None
    except ValidationError as exc:
        err = exc.errors()[0]
        where = ".".join(str(p) for p in err["loc"])
        reason = f"{where}: {err['msg']}" if where else err["msg"]
        raise InputError(
            f"{folder}: unreadable model.json or normalisers.json ({reason})"
        ) from None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InputError(f"{folder}: unreadable model.json or normalisers.json ({exc})") from None
    # the limits the model was trained with travel with it; older folders name the profile only
    profile = stored or pepper.load_profile(name)  # unknown → InputError now, not mid-performance
    return ModelFolder(folder, info, norm, audio, profile)


def _stored_profile(limits: dict[str, dict[str, float]], name: str) -> pepper.RobotProfile:
    table = np.array(
        [[limits[j][k] for k in ("lower", "upper", "velocity")] for j in pepper.JOINTS]
    )
    return pepper.RobotProfile(name, "from the dataset", table[:, 0], table[:, 1], table[:, 2])


def load_model(model_dir: PathLike) -> tuple[nn.Module, ModelInfo, dict[str, Any]]:
    """(torch model with its trained weights, model.json, normalisers.json) of a model folder."""
    folder = load(model_dir)
    return folder.torch_model(), folder.info, folder.norm


# --------------------------------------------------------------------------------------------------
# onnxruntime


def session(path: PathLike, *, threads: int = 1) -> ort.InferenceSession:
    """An onnxruntime CPU session over the graph `path`, `threads` intra-op threads, sequential.

    One thread by default: these graphs are a few thousand multiply-adds, and thread hand-offs
    would cost more than the arithmetic. InputError (one line) when `path` is missing or not a
    loadable model.
    """
    import onnxruntime as ort

    name = os.fspath(path)
    if not Path(name).is_file():
        raise InputError(f"{name}: ONNX model not found")
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = threads
    opts.inter_op_num_threads = 1
    opts.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    opts.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    try:
        return ort.InferenceSession(name, opts, providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime raises its own exception types
        text = str(exc).strip()
        reason = text.splitlines()[0] if text else type(exc).__name__
        raise InputError(f"{name}: not a loadable ONNX model ({reason})") from None


class OnnxFrameModel:
    """`model_step.onnx` (LSTM: `(1, F)` + state `(1, 1, H)` ×2 → `(1, 11)` + state; Aud2Motion:
    one state) or, for the MLP, `model.onnx` (`(N, F)` → `(N, 11)`), inputs and outputs taken by
    position, through onnxruntime one frame per `step`: a `robot.online.FrameModel` for live mode
    (one thread: the graph is tiny, hand-offs cost)."""

    def __init__(self, path: PathLike) -> None:
        name = os.fspath(path)
        self.session = session(path)
        inputs = self.session.get_inputs()
        if len(self.session.get_outputs()) != len(inputs):
            raise InputError(f"{name}: expected inputs x[, states…] and outputs y[, states…]")
        self.input_names = [i.name for i in inputs]
        self.output_names = [o.name for o in self.session.get_outputs()]
        dim = inputs[0].shape[-1]
        self.n_features = dim if isinstance(dim, int) else None
        self.state_shapes: list[tuple[int, ...]] = []
        for i in inputs[1:]:  # recurrent state: (h, c) of an LSTM, h of a GRU
            if not all(isinstance(d, int) for d in i.shape):
                raise InputError(f"{name}: state input {i.name} needs a fixed shape, got {i.shape}")
            self.state_shapes.append(tuple(int(d) for d in i.shape))
        self.stateful = bool(self.state_shapes)
        self.reset()

    def reset(self) -> None:
        self.states = [np.zeros(shape, np.float32) for shape in self.state_shapes]

    def step(self, features01: np.ndarray) -> np.ndarray:
        x = np.asarray(features01, np.float32).reshape(1, -1)
        feed: dict[str, Any] = dict(zip(self.input_names, [x, *self.states], strict=True))
        y, *self.states = self.session.run(self.output_names, feed)
        return np.asarray(y, np.float32).reshape(-1)
