"""Mocap takes for tests: a stretch of a real bvhtools BVH with real speech beside it."""

from __future__ import annotations

import shutil
from pathlib import Path

from gesturebank.mocap.bvh import read_bvh, write_bvh

# test.bvh (FreeMoCap, LAFAN1-style names, cm, 30 fps): 4.2 s from frame 6225, where both arms
# gesture inside Pepper's limits (most of the file has the right elbow bent past RElbowRoll's
# 89.5° limit), as long as speech/arctic_a0007.wav (4.0 s).
BVH = "bvhtools/testBvhFiles/test.bvh"
SPEECH = "speech/arctic_a0007.wav"
START, FRAMES = 6225, 126


def mocap_take(samples: Path, folder: Path, *, name: str = "take") -> Path:
    """Write `folder/<name>.bvh` (the stretch above) and `<name>.wav` (the speech); returns the
    BVH path."""
    folder.mkdir(parents=True, exist_ok=True)
    bvh = folder / f"{name}.bvh"
    write_bvh(bvh, read_bvh(samples / BVH).frames(START, START + FRAMES))
    shutil.copy(samples / SPEECH, folder / f"{name}.wav")
    return bvh
