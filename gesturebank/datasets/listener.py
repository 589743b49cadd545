"""The listener target (seed 004; `train --target listener`): what a model that predicts a
listener's head sees and is scored on.

Input: the take's audio features at the clip's frames — one audio track per take, so the
partner's speech is in the clip's own `audio` — plus one column, the partner's speaking flag
(`partner_speaking`, 1.0 where the partner speaks). Target: the clip's head joints
(`pepper.HEAD_JOINTS`) on the frames where the clip's person is listening (role "listening");
every other entry is masked, so the loss (Eq. 3.15 on known entries) is on listening frames
only. A clip without partner gives no listener example.
"""

from __future__ import annotations

import numpy as np

from gesturebank.datasets.partners import LISTENING
from gesturebank.robot import pepper

HEAD = np.isin(np.array(pepper.JOINTS), pepper.HEAD_JOINTS)  # (11,) bool


def listener_inputs(*, audio: np.ndarray, partner_speaking: np.ndarray) -> np.ndarray:
    """`audio (n, F)` and `partner_speaking (n,)` bool → the model's input `(n, F + 1)` float32."""
    flag = np.asarray(partner_speaking, np.float32).reshape(-1, 1)
    return np.concatenate([np.asarray(audio, np.float32), flag], axis=1)


def listener_mask(*, mask: np.ndarray, role: np.ndarray) -> np.ndarray:
    """`mask (n, 11)` (known angles) → known head angles on listening frames only."""
    return np.asarray(mask, bool) & HEAD[None, :] & (np.asarray(role) == LISTENING)[:, None]
