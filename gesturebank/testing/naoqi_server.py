"""A stand-in NAOqi for the tests and `benchmarks/playback.py`: a real standalone qi session
serving a recording ALMotion.

Run as a script (a subprocess with a bounded lifetime, so a test can kill it like a robot that
drops off the network):

    python naoqi_server.py --lifetime 30 --pose '[11 angles in pepper.JOINTS order]'

It prints `READY tcp://127.0.0.1:PORT` once the service is registered. `NaoqiServer` below starts
it and reads the call log back over qi. The service knows every real Pepper joint (and rejects
others, as ALMotion does) and stamps each call with time.monotonic() on arrival, which on Linux is
the same clock as the client's time.monotonic().
"""

from __future__ import annotations

import argparse
import itertools
import json
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

# Every joint of Pepper's ALMotion (NAOqi 2.5 documentation), not only the 11 gesturebank drives.
PEPPER_JOINTS = (
    "HeadYaw",
    "HeadPitch",
    "LShoulderPitch",
    "LShoulderRoll",
    "LElbowYaw",
    "LElbowRoll",
    "LWristYaw",
    "LHand",
    "RShoulderPitch",
    "RShoulderRoll",
    "RElbowYaw",
    "RElbowRoll",
    "RWristYaw",
    "RHand",
    "HipRoll",
    "HipPitch",
    "KneePitch",
    "WheelFL",
    "WheelFR",
    "WheelB",
)
STARTED = "READY"


class RecordingMotion:
    """ALMotion look-alike: keeps a pose per joint and logs every call with its arrival time."""

    def __init__(self, pose: dict[str, float]) -> None:
        self.pose = {j: 0.0 for j in PEPPER_JOINTS} | pose
        self.log: list[dict[str, Any]] = []
        self.lock = threading.Lock()

    def _check(self, names: list[str]) -> list[str]:
        names = [names] if isinstance(names, str) else list(names)
        for n in names:
            if n not in self.pose:
                raise RuntimeError(f"ALMotion: unknown joint {n!r}")
        return names

    def _log(self, entry: dict[str, Any]) -> None:
        with self.lock:
            self.log.append(entry)

    def setAngles(self, names: list[str], angles: list[float], fractionMaxSpeed: float) -> None:
        t = time.monotonic()
        names = self._check(names)
        values = [float(a) for a in angles]
        with self.lock:
            self.pose.update(zip(names, values, strict=True))
        self._log(
            {
                "call": "setAngles",
                "t": t,
                "names": names,
                "angles": values,
                "fraction": float(fractionMaxSpeed),
            }
        )

    def angleInterpolation(
        self,
        names: list[str],
        angleLists: list[list[float]],
        timeLists: list[list[float]],
        isAbsolute: bool,
    ) -> None:
        t = time.monotonic()
        names = self._check(names)
        if len(angleLists) != len(names) or len(timeLists) != len(names):
            raise RuntimeError("ALMotion: one angle list and one time list per joint")
        for times in timeLists:
            if not times or times[0] <= 0 or any(b <= a for a, b in itertools.pairwise(times)):
                raise RuntimeError("ALMotion: time lists must be positive and increasing")
        self._log(
            {
                "call": "angleInterpolation",
                "t": t,
                "names": names,
                "angleLists": angleLists,
                "timeLists": timeLists,
                "isAbsolute": bool(isAbsolute),
            }
        )
        time.sleep(max(ts[-1] for ts in timeLists))  # blocking for the motion, like the robot
        with self.lock:
            self.pose.update({n: float(a[-1]) for n, a in zip(names, angleLists, strict=True)})
        self._log({"call": "angleInterpolationDone", "t": time.monotonic()})

    def getAngles(self, names: list[str], useSensors: bool) -> list[float]:
        names = self._check(names)
        self._log({"call": "getAngles", "t": time.monotonic(), "names": names})
        with self.lock:
            return [self.pose[n] for n in names]

    def wakeUp(self) -> None:
        self._log({"call": "wakeUp", "t": time.monotonic()})

    def rest(self) -> None:
        self._log({"call": "rest", "t": time.monotonic()})

    def killTasksUsingResources(self, names: list[str]) -> None:
        self._log({"call": "killTasksUsingResources", "t": time.monotonic()})

    def callLog(self) -> str:
        with self.lock:
            return json.dumps(self.log)


def serve(lifetime_s: float, pose: dict[str, float]) -> None:
    import qi

    qi.logging.setLevel(qi.logging.ERROR)
    session = qi.Session()
    session.listenStandalone("tcp://127.0.0.1:0")
    session.registerService("ALMotion", RecordingMotion(pose))
    print(STARTED, session.endpoints()[0], flush=True)
    time.sleep(lifetime_s)  # bounded lifetime: never outlives a crashed test run for long
    session.close()


class NaoqiServer:
    """Starts `serve` in a subprocess; `url`, `calls()`, `kill()`; a context manager."""

    def __init__(self, pose: dict[str, float] | None = None, lifetime_s: float = 60.0) -> None:
        args = ["--lifetime", str(lifetime_s), "--pose", json.dumps(pose or {})]
        self.proc = subprocess.Popen(
            [sys.executable, str(Path(__file__).resolve()), *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        assert self.proc.stdout is not None
        deadline = time.monotonic() + 20
        line = ""
        while not line.startswith(STARTED):
            line = self.proc.stdout.readline()
            if not line and (self.proc.poll() is not None or time.monotonic() > deadline):
                raise RuntimeError("naoqi test server did not start")
        self.url = line.split()[1]

    def calls(self) -> list[dict[str, Any]]:
        """The server's call log, read over a fresh qi connection."""
        import qi

        session = qi.Session()
        session.connect(self.url)
        try:
            return list(json.loads(session.service("ALMotion").callLog()))
        finally:
            session.close()

    def kill(self) -> None:
        self.proc.kill()
        self.proc.wait(timeout=10)

    def __enter__(self) -> NaoqiServer:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.proc.poll() is None:
            self.kill()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--lifetime", type=float, default=60.0)
    parser.add_argument("--pose", default="{}", help="JSON {joint: angle} of the starting pose")
    ns = parser.parse_args()
    serve(ns.lifetime, json.loads(ns.pose))
