"""Which BVH joints stand for the points gesturebank needs: the name table of
`gesturebank/data/mocap-names.toml` (CMU, Trinity/GENEA, BEAT, LAFAN1, Mixamo, …), extended per
build by `mocap.names` (BVH joint name → point)."""

from __future__ import annotations

import tomllib
from collections.abc import Mapping, Sequence
from functools import cache
from importlib import resources

from gesturebank.errors import InputError

BODY = (
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hip",
    "right_hip",
)
LEGS = ("left_knee", "right_knee", "left_ankle", "right_ankle")
FACE = ("nose", "left_eye", "right_eye", "left_ear", "right_ear")
POINTS = (*BODY, *LEGS, "head", *FACE)  # face points: a skeleton that has them (ours does)
REQUIRED = (*BODY, "head")  # "head" is not needed when all the face points are there


@cache
def _table() -> dict[str, object]:
    text = resources.files("gesturebank").joinpath("data/mocap-names.toml").read_text("utf-8")
    return tomllib.loads(text)


def name_table() -> dict[str, tuple[str, ...]]:
    """Point → the joint names that stand for it, in the order they are tried."""
    points = _table()["points"]
    assert isinstance(points, dict)
    return {p: tuple(points.get(p, ())) for p in POINTS}


def face_model() -> dict[str, tuple[float, float, float]]:
    """Face point → (forward, up, left) metres from the head joint (see the data file)."""
    face = _table()["face"]
    assert isinstance(face, dict)
    return {k: (float(face[k][0]), float(face[k][1]), float(face[k][2])) for k in FACE}


def _key(name: str) -> str:
    """'mixamorig:LeftArm' → 'leftarm': a namespace prefix dropped, case folded."""
    return name.rsplit(":", 1)[-1].casefold()


def map_joints(
    joints: Sequence[str], *, extra: Mapping[str, str] | None = None, source: str = "BVH"
) -> dict[str, int]:
    """Point → index into `joints` for every point found (knees and ankles may be missing).

    `extra` (config `mocap.names`, BVH joint name → point) comes before the table. InputError,
    one line naming `source`, the points not found, the joint names the file has and the config
    key, when a required point is missing.
    """
    extra = dict(extra or {})
    bad = sorted(set(extra.values()) - set(POINTS))
    if bad:
        raise InputError(
            f"mocap.names: unknown point(s) {', '.join(bad)}; points: {', '.join(POINTS)}"
        )
    by_key: dict[str, int] = {}
    for i, j in enumerate(joints):
        by_key.setdefault(_key(j), i)
    found: dict[str, int] = {}
    for joint, point in extra.items():
        if _key(joint) in by_key:
            found.setdefault(point, by_key[_key(joint)])
    for point, candidates in name_table().items():
        for candidate in candidates:
            if point not in found and _key(candidate) in by_key:
                found[point] = by_key[_key(candidate)]
    has_face = all(p in found for p in FACE)
    missing = [p for p in REQUIRED if p not in found and not (p == "head" and has_face)]
    if missing:
        have = ", ".join(j for j in joints if not j.endswith("_End"))
        example = f'mocap.names = {{ "{joints[0]}" = "{missing[0]}", … }}'
        raise InputError(
            f"{source}: no joint found for {', '.join(missing)}; the file has: {have}; map "
            f"them with the config key mocap.names, e.g. {example}"
        )
    return found
