"""The speech-to-motion models by name (`gesturebank train --model NAME`), extensible by plug-ins.

A plug-in declares `[project.entry-points."gesturebank.models"] mine = "pkg:MyModel"`. A model
class is an `nn.Module` keeping the contract of `train.contract.SpeechToMotion`:

    kind: str, causal: bool, n_features: int
    config_sections: tuple[str, ...]    the [train.X] sections its constructor's keywords come from
    schedule(config) -> schedule.Schedule   optimiser, rates, batches, epochs, windows
    forward(x) → angles01: MLP (N, F) → (N, 11); every other model (B, T, F) → (B, T, 11)

and optionally the hooks declared there: `loss`, `validation_loss`, `stages` with
`stage_parameters`, `step_module` (live mode), `onnx_inputs`, and `section_model` (a plug-in's own
`[train.NAME]` section, validated with it). Its architecture (model.json) is derived from its
constructor and config sections (`models.build`).

Listing the names imports nothing heavy (the classes load on first use).
"""

from __future__ import annotations

from gesturebank.registry import Registry
from gesturebank.train.contract import SpeechToMotion

# Model classes: each called with (n_features, **architecture) gives a SpeechToMotion.
MODELS: Registry[SpeechToMotion] = Registry("model", "gesturebank.models")

_BUILTINS = {
    "mlp": "gesturebank.train.models.dissertation:MLP",
    "lstm": "gesturebank.train.models.dissertation:LSTMModel",
    "aud2motion": "gesturebank.train.models.aud2motion:Aud2Motion",
    "aud2pose": "gesturebank.train.models.aud2pose:Aud2Pose",
    "blstm": "gesturebank.train.models.blstm:SpanBLSTM",
    "cvae": "gesturebank.train.models.cvae:CVAE",
    "aud2repr2pose": "gesturebank.train.models.aud2repr2pose:Aud2Repr2Pose",
    "dcccae": "gesturebank.train.models.dcccae:DCCCAE",
}
for _name, _target in _BUILTINS.items():
    MODELS.register_lazy(_name, _target)
