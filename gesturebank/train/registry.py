"""The speech-to-motion models by name (`gesturebank train --model NAME`), extensible by plug-ins.

A plug-in declares `[project.entry-points."gesturebank.models"] mine = "pkg:MyModel"`. A model
class (an `nn.Module`) provides:

    kind: str, causal: bool, n_features: int
    from_config(n_features, config: TrainConfig)    classmethod, a fresh model
    architecture() -> dict   /   from_architecture(arch)    plain data ↔ the same module
    schedule(config) -> trainer.Schedule            optimiser, rates, batches, epochs, windows
    forward(x) → angles01: MLP (N, F) → (N, 11); every other model (B, T, F) → (B, T, 11)
    loss(x, y, mask) -> tensor                      optional; masked MSE of forward otherwise
    step_module() -> (module, state shapes)         causal models with state, for live mode

Listing the names imports nothing heavy (the classes load on first use).
"""

from __future__ import annotations

from typing import Any

from gesturebank.registry import Registry

MODELS: Registry[Any] = Registry("model", "gesturebank.models")

_BUILTINS = {
    "mlp": "gesturebank.train.models:MLP",
    "lstm": "gesturebank.train.models:LSTMModel",
    "aud2motion": "gesturebank.train.aud2motion:Aud2Motion",
    "aud2pose": "gesturebank.train.aud2pose:Aud2Pose",
    "blstm": "gesturebank.train.blstm:SpanBLSTM",
    "cvae": "gesturebank.train.cvae:CVAE",
    "aud2repr2pose": "gesturebank.train.aud2repr2pose:Aud2Repr2Pose",
    "dcccae": "gesturebank.train.dcccae:DCCCAE",
}
for _name, _target in _BUILTINS.items():
    MODELS.register_lazy(_name, _target)
