"""Who does not veto the speaker (issue 41): where no mouth decides who speaks (a blurred face,
a face too small, dubbed speech), people with their back to the camera do not set the scale when
somebody faces it, and a much smaller person or one at the edge of the picture is a bystander
(`tracking.veto_min_size`, `tracking.veto_min_centrality`). Pure functions over the candidates'
scores and keypoints; `extract.tracking` chooses with them.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from gesturebank.config import TrackingConfig
from gesturebank.geometry import torso_vectors
from gesturebank.skeletons import COCO17


def seen_from_the_front(xy: np.ndarray) -> np.ndarray:
    """`(T, P)` whether each slot's torso (COCO-17 `xy (T, P, 17, 2)`, image y down) is seen
    from the front: its left shoulder right of its up direction (up: mid-hips to mid-shoulders,
    or mid-shoulders to the nose where the hips are unseen); False where unknown."""
    i = COCO17.index
    ls, rs, nose = (
        xy[..., i["left_shoulder"], :],
        xy[..., i["right_shoulder"], :],
        xy[..., i["nose"], :],
    )
    across, up = torso_vectors(
        ls, rs, left_hip=xy[..., i["left_hip"], :], right_hip=xy[..., i["right_hip"], :]
    )
    hips = np.isfinite(up).all(axis=-1, keepdims=True)
    up = np.where(hips, up, nose - (ls + rs) / 2)
    turn = across[..., 0] * up[..., 1] - across[..., 1] * up[..., 0]
    with np.errstate(invalid="ignore"):
        return np.asarray(turn < 0)


def front_share(
    ids: np.ndarray, front: np.ndarray, *, cands: Mapping[int, object]
) -> dict[int, float]:
    """Per candidate, the share of its frames with its torso seen from the front: `ids (n, P)`
    the slots' track ids and `front (n, P)` (`seen_from_the_front`) over a span."""
    return {k: float(front[ids == k].mean()) if (ids == k).any() else 0.0 for k in cands}


def bystanders_left_out(
    cands: dict[int, dict[str, float]], front: dict[int, float], *, config: TrackingConfig
) -> dict[int, dict[str, float]]:
    """The candidates who can veto the choice where no mouth decides (issue 41). People seen
    from behind (torso turned away in over half their frames, `front`) do not set the scale
    when somebody faces us; of the rest, a candidate smaller than `veto_min_size` of the biggest
    (their "size" terms) or at the edge of the picture ("centrality" below
    `veto_min_centrality`) is a bystander. When that leaves nobody, all of them."""
    turned = {k for k in cands if front.get(k, 0.0) < 0.5}
    facing_us = {k: v for k, v in cands.items() if k not in turned} or cands
    biggest = max(v["size"] for v in facing_us.values())
    rivals = {
        k: v
        for k, v in facing_us.items()
        if v["size"] >= config.veto_min_size * biggest
        and v["centrality"] >= config.veto_min_centrality
    }
    return rivals or cands
