"""BVH motion files: parse, forward kinematics (vectorised over frames) and write.

A BVH file is a joint hierarchy (per joint: OFFSET from its parent, CHANNELS in the order the
values come) and a MOTION block (frame count, frame time, one row of channel values per frame).
Conventions followed, as Blender's importer and the `bvh` package read them:

- rotations are in degrees; a joint's local rotation is the product of its rotation channels in
  the order listed (`Zrotation Yrotation Xrotation` → Rz·Ry·Rx), so any Euler order works;
- a joint's local translation is its OFFSET, except for the components it has position channels
  for, which replace it (a root's position is absolute; Blender rigs give every joint one);
- `End Site` blocks become joints without channels, named `<parent>_End`.

Positions come out in the file's own unit; `gesturebank.mocap.pose` decides the unit.
"""

from __future__ import annotations

import io
import os
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from gesturebank.errors import InputError
from gesturebank.geometry import axis_rotations

AXES = {"X": 0, "Y": 1, "Z": 2}
CHANNELS = tuple(f"{a}{kind}" for kind in ("position", "rotation") for a in "XYZ")


@dataclass(frozen=True, eq=False)
class Motion:
    """A parsed BVH file.

    names: joint names in file order (parents come before their children); parents: index of
    each joint's parent (−1 for a root); offsets: (J, 3) float64 in the file's unit; channels:
    per joint, its channel names in file order (() for an end site); end_site: per joint;
    values: (T, C) float64 channel values, C = the sum of channel counts, in file order;
    frame_time: seconds per frame.
    """

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray
    channels: tuple[tuple[str, ...], ...]
    end_site: tuple[bool, ...]
    values: np.ndarray
    frame_time: float

    def __post_init__(self) -> None:
        n = len(self.names)
        offsets = np.asarray(self.offsets, dtype=np.float64)
        values = np.asarray(self.values, dtype=np.float64)
        if offsets.shape != (n, 3) or len(self.parents) != n or len(self.channels) != n:
            raise InputError(f"BVH: {n} joints need {n} parents, offsets (n, 3) and channel lists")
        if any(p >= i for i, p in enumerate(self.parents)):
            raise InputError("BVH: a joint must come after its parent")
        bad = {c for chans in self.channels for c in chans} - set(CHANNELS)
        if bad:
            raise InputError(f"BVH: unknown channel(s) {', '.join(sorted(bad))}")
        width = sum(len(c) for c in self.channels)
        if values.ndim != 2 or values.shape[1] != width:
            raise InputError(f"BVH: motion needs {width} values per frame, got {values.shape}")
        if not self.frame_time > 0:
            raise InputError(f"BVH: frame time must be positive, got {self.frame_time}")
        object.__setattr__(self, "offsets", offsets)
        object.__setattr__(self, "values", values)

    def __len__(self) -> int:
        return len(self.values)

    @property
    def index(self) -> dict[str, int]:
        return {n: i for i, n in enumerate(self.names)}

    @property
    def times(self) -> np.ndarray:
        """(T,) seconds from the first frame."""
        return np.arange(len(self.values)) * self.frame_time

    def columns(self, joint: str) -> slice:
        """The columns of `values` that hold `joint`'s channels."""
        i = self.index[joint]
        start = sum(len(c) for c in self.channels[:i])
        return slice(start, start + len(self.channels[i]))

    def frames(self, start: int, stop: int) -> Motion:
        """Frames [start, stop)."""
        return replace(self, values=self.values[start:stop])


def _tokens(text: str) -> list[str]:
    return re.findall(r"[{}]|[^\s{}]+", text)


def parse_bvh(text: str, *, name: str = "BVH") -> Motion:
    """A Motion from the text of a BVH file; InputError naming `name` and the problem."""
    head, sep, motion = text.partition("MOTION")
    if not sep:
        raise InputError(f"{name}: no MOTION section (not a BVH file?)")
    tok = _tokens(head)
    if not tok or tok[0] != "HIERARCHY":
        raise InputError(f"{name}: does not start with HIERARCHY (not a BVH file?)")
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[tuple[str, ...]] = []
    ends: list[bool] = []
    stack: list[int] = []
    i = 1
    try:
        while i < len(tok):
            word = tok[i]
            if word in ("ROOT", "JOINT") or word == "End":
                if word == "End":
                    if tok[i + 1] != "Site" or not stack:
                        raise InputError(f"{name}: 'End' must be 'End Site' inside a joint")
                    label, end = f"{names[stack[-1]]}_End", True
                else:
                    label, end = tok[i + 1], False
                if tok[i + 2] != "{" or tok[i + 3] != "OFFSET":
                    raise InputError(f"{name}: joint {label!r}: expected '{{ OFFSET x y z'")
                parents.append(stack[-1] if stack else -1)
                names.append(label)
                offsets.append([float(v) for v in tok[i + 4 : i + 7]])
                ends.append(end)
                i += 7
                chans: tuple[str, ...] = ()
                if not end and tok[i] == "CHANNELS":
                    count = int(tok[i + 1])
                    # "XROTATION" and "xrotation" occur too; the axis letter and kind are what count
                    chans = tuple(c[:1].upper() + c[1:].lower() for c in tok[i + 2 : i + 2 + count])
                    i += 2 + count
                channels.append(chans)
                stack.append(len(names) - 1)
            elif word == "}":
                stack.pop()
                i += 1
            else:
                raise InputError(f"{name}: unexpected {word!r} in the hierarchy")
    except (IndexError, ValueError):
        raise InputError(f"{name}: the hierarchy ends early or has a bad number") from None
    if stack or not names:
        raise InputError(f"{name}: unbalanced braces or no joints in the hierarchy")
    frames = re.search(r"Frames:\s*(\d+)", motion)
    period = re.search(r"Frame\s+Time:\s*(\S+)", motion)
    if frames is None or period is None:
        raise InputError(f"{name}: MOTION needs 'Frames:' and 'Frame Time:' lines")
    n = int(frames.group(1))
    width = sum(len(c) for c in channels)
    try:
        frame_time = float(period.group(1))
        data = np.array(motion[period.end() :].split(), dtype=np.float64)
    except ValueError:
        raise InputError(f"{name}: the motion data holds something that is not a number") from None
    if data.size != n * width:
        raise InputError(
            f"{name}: 'Frames: {n}' × {width} channels = {n * width} values, found {data.size}"
        )
    try:
        return Motion(
            tuple(names),
            tuple(parents),
            np.array(offsets, dtype=np.float64).reshape(-1, 3),
            tuple(channels),
            tuple(ends),
            data.reshape(n, width),
            frame_time,
        )
    except InputError as exc:  # name the file
        raise InputError(f"{name}: {str(exc).removeprefix('BVH: ')}") from None


def read_bvh(path: str | os.PathLike[str]) -> Motion:
    """Parse the BVH file at `path`; InputError naming the file on any problem."""
    name = os.fspath(path)
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise InputError(f"{name}: cannot read ({exc.strerror or exc})") from None
    return parse_bvh(text, name=name)


def rotation(axis: int, degrees: np.ndarray) -> np.ndarray:
    """(T, 3, 3) right-handed rotations by `degrees (T,)` about x (0), y (1) or z (2)."""
    return axis_rotations(axis, np.deg2rad(np.asarray(degrees, dtype=np.float64)))


def local_transforms(motion: Motion) -> tuple[np.ndarray, np.ndarray]:
    """Per joint, its local rotation (T, J, 3, 3) and translation (T, J, 3), file units."""
    t, n = len(motion.values), len(motion.names)
    rot = np.broadcast_to(np.eye(3), (t, n, 3, 3)).copy()
    trans = np.broadcast_to(motion.offsets, (t, n, 3)).copy()
    col = 0
    for j, chans in enumerate(motion.channels):
        for name in chans:
            axis, kind = AXES[name[0]], name[1:]
            v = motion.values[:, col]
            if kind == "position":
                trans[:, j, axis] = v
            else:
                rot[:, j] = rot[:, j] @ rotation(axis, v)
            col += 1
    return rot, trans


def forward_kinematics(motion: Motion) -> tuple[np.ndarray, np.ndarray]:
    """Global joint positions (T, J, 3) in the file's unit and rotations (T, J, 3, 3)."""
    rot, trans = local_transforms(motion)
    pos = np.empty_like(trans)
    glob = np.empty_like(rot)
    for j, p in enumerate(motion.parents):
        if p < 0:
            pos[:, j], glob[:, j] = trans[:, j], rot[:, j]
        else:
            pos[:, j] = pos[:, p] + np.einsum("tij,tj->ti", glob[:, p], trans[:, j])
            glob[:, j] = glob[:, p] @ rot[:, j]
    return pos, glob


def rest_positions(motion: Motion) -> np.ndarray:
    """(J, 3) joint positions of the rest pose (every channel 0 but the offsets), file units."""
    pos = np.zeros((len(motion.names), 3))
    for j, p in enumerate(motion.parents):
        pos[j] = motion.offsets[j] + (pos[p] if p >= 0 else 0.0)
    return pos


def format_bvh(motion: Motion, *, decimals: int = 6) -> str:
    """The text of `motion` as a BVH file (tabs, `decimals` digits after the point)."""
    out = ["HIERARCHY"]
    children: dict[int, list[int]] = {}
    for j, p in enumerate(motion.parents):
        children.setdefault(p, []).append(j)
    num = f"{{:.{decimals}f}}"

    def block(j: int, depth: int) -> None:
        pad = "\t" * depth
        if motion.end_site[j]:
            out.append(f"{pad}End Site")
        else:
            out.append(f"{pad}{'ROOT' if motion.parents[j] < 0 else 'JOINT'} {motion.names[j]}")
        out.append(f"{pad}{{")
        out.append(f"{pad}\tOFFSET " + " ".join(num.format(v) for v in motion.offsets[j]))
        if not motion.end_site[j]:
            chans = motion.channels[j]
            out.append(f"{pad}\tCHANNELS {len(chans)}" + "".join(f" {c}" for c in chans))
        for c in children.get(j, []):
            block(c, depth + 1)
        out.append(f"{pad}}}")

    for root in children.get(-1, []):
        block(root, 0)
    out += ["MOTION", f"Frames: {len(motion.values)}", f"Frame Time: {motion.frame_time:.8f}"]
    body = io.StringIO()
    np.savetxt(body, np.where(motion.values == 0, 0.0, motion.values), fmt=f"%.{decimals}f")
    return "\n".join(out) + "\n" + body.getvalue()


def write_bvh(path: str | os.PathLike[str], motion: Motion, *, decimals: int = 6) -> Path:
    """Write `motion` to `path` atomically; returns the path."""
    from gesturebank.fileio import write_bytes_atomic

    out = Path(path)
    write_bytes_atomic(out, format_bvh(motion, decimals=decimals).encode())
    return out
