"""What a speech-to-motion model is (`SpeechToMotion`) and the optional hooks the training loop,
the export and the model folder look for, each a runtime-checkable Protocol.

A model is an `nn.Module` class registered in `train.registry.MODELS` (built-in, or a plug-in's
entry point). Its architecture is the keyword parameters of its constructor, read from the config
sections it names (`config_sections`, first section holding the key wins): `models.build` builds
it from a `TrainConfig` and writes and reads those values as model.json's "architecture".

A plug-in model may bring its own `[train.NAME]` section: it declares `section_model`, the
pydantic model of that section (`OwnSection`); `TrainConfig` validates the section with it.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, ClassVar, Protocol, runtime_checkable

if TYPE_CHECKING:
    import torch
    from pydantic import BaseModel
    from torch import nn

    from gesturebank.config import TrainConfig
    from gesturebank.datasets.torch import Segment
    from gesturebank.train.schedule import Schedule


@runtime_checkable
class SpeechToMotion(Protocol):
    """The contract every model keeps.

    forward: z-normalised audio → angles in [0, 1]: a `FrameWise` model `(N, F) → (N, 11)`,
    every other `(B, T, F) → (B, T, 11)`.
    """

    kind: ClassVar[str]  # its registry name
    causal: ClassVar[bool]  # each output frame depends on past audio only (live mode needs it)
    config_sections: ClassVar[tuple[str, ...]]  # [train.X] sections holding its architecture
    n_features: int

    def schedule(self, config: TrainConfig) -> Schedule:
        """Optimiser, rates, batches, epochs and training windows (`train.schedule`)."""
        ...

    def forward(self, x: torch.Tensor) -> torch.Tensor: ...


@runtime_checkable
class FrameWise(Protocol):
    """A model over single frames, `(N, F) → (N, 11)` (the MLP)."""

    frame_wise: ClassVar[bool]


@runtime_checkable
class OwnLoss(Protocol):
    """A training loss of its own; the masked MSE of `forward` otherwise (Eq. 3.15)."""

    def loss(self, x: torch.Tensor, y: torch.Tensor, mask: torch.Tensor) -> torch.Tensor: ...


@runtime_checkable
class OwnValidation(Protocol):
    """A validation loss of its own; `torch_runtime.validation_loss` otherwise."""

    def validation_loss(self, segments: Sequence[Segment]) -> float: ...


@runtime_checkable
class Staged(Protocol):
    """Trained in stages: `stages` sets each up and yields its name; `stage_parameters` are
    what the current stage trains (and `schedule` may depend on the stage)."""

    def stages(self, train_segments: Sequence[Segment]) -> Iterator[str]: ...

    def stage_parameters(self) -> Iterator[nn.Parameter]: ...


@runtime_checkable
class Stateful(Protocol):
    """A causal model with state, for live mode: the one-frame graph and its state shapes."""

    def step_module(self) -> tuple[nn.Module, list[tuple[int, ...]]]: ...


@runtime_checkable
class ExtraOnnxInputs(Protocol):
    """Graph inputs beside the audio (the CVAE's z), name → shape."""

    def onnx_inputs(self) -> dict[str, tuple[int, ...]]: ...


@runtime_checkable
class OwnSection(Protocol):
    """A plug-in model's own `[train.NAME]` section, validated by this pydantic model."""

    section_model: ClassVar[type[BaseModel]]
