"""Angles for `ALMotion.angleInterpolation(names, angleLists, timeLists, isAbsolute)`, the call
Choregraphe timelines and NAOqi scripts use: a JSON file of the four arguments, and a small
Python script that plays it on a robot with the `qi` SDK.

Times are seconds from the call; the first frame comes at `lead_s` (the move from wherever the
robot is). Angles must already be finite, inside the limits and slow enough (`commands` makes
them so with the same safety as `gesturebank replay`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from gesturebank.fileio import write_bytes_atomic
from gesturebank.robot.pepper import JOINTS

SCRIPT = '''\
"""Play {json_name} on Pepper: python {script_name} [tcp://ROBOT:9559] (needs the qi SDK)."""
import json
import os
import sys

import qi

url = sys.argv[1] if len(sys.argv) > 1 else "tcp://127.0.0.1:9559"
here = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(here, "{json_name}")) as f:
    data = json.load(f)
app = qi.Application(["gesturebank-export", "--qi-url=" + url])
app.start()
motion = app.session.service("ALMotion")
motion.wakeUp()
motion.angleInterpolation(data["names"], data["angleLists"], data["timeLists"], True)
'''


def naoqi_arguments(
    *, times: np.ndarray, angles: np.ndarray, lead_s: float, profile: str
) -> dict[str, object]:
    """The angleInterpolation arguments of `angles (N, 11)` rad at `times (N,)` s."""
    t = np.asarray(times, dtype=np.float64)
    t = t - t[0] + lead_s
    a = np.asarray(angles, dtype=np.float64)
    return {
        "names": list(JOINTS),
        "angleLists": [[round(float(v), 6) for v in a[:, j]] for j in range(len(JOINTS))],
        "timeLists": [[round(float(v), 4) for v in t]] * len(JOINTS),
        "isAbsolute": True,
        "robot_profile": profile,
    }


def write_naoqi(
    path: str | os.PathLike[str],
    *,
    times: np.ndarray,
    angles: np.ndarray,
    lead_s: float,
    profile: str,
) -> tuple[Path, Path]:
    """Write `path` (.json) and the script beside it (.py); returns both paths."""
    out = Path(path).with_suffix(".json")
    script = out.with_suffix(".py")
    args = naoqi_arguments(times=times, angles=angles, lead_s=lead_s, profile=profile)
    write_bytes_atomic(out, json.dumps(args).encode())
    text = SCRIPT.format(json_name=out.name, script_name=script.name)
    write_bytes_atomic(script, text.encode())
    return out, script
