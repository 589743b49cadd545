"""A stand-in NAOqi for the tests and `benchmarks/playback.py`: a real standalone qi session
serving a recording ALMotion and ALAudioDevice.

Run as a script (a subprocess with a bounded lifetime, so a test can kill it like a robot that
drops off the network):

    python naoqi_server.py --lifetime 30 --pose '{"HeadYaw": 0.1, ...}' --audio-delay 0.3

It prints `READY tcp://127.0.0.1:PORT` once the services are registered. `NaoqiServer` below
starts it and reads the call log back over qi. ALMotion knows every real Pepper joint (and
rejects others, as ALMotion does). ALAudioDevice takes `sendRemoteBufferToOutput(nbOfFrames,
buffer)` as NAOqi does (16-bit interleaved stereo, at most 16384 frames a call); its first buffer
opens the output, which takes `--audio-delay` seconds, and the call answers once the sound has
started (logged as `audioStart`). One log holds both services' calls, in arrival order, each
stamped with time.monotonic() on arrival: on Linux the same clock as the client's.
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
MAX_FRAMES = 16384  # NAOqi's limit of one sendRemoteBufferToOutput call


class RecordingMotion:
    """ALMotion look-alike: keeps a pose per joint and logs every call with its arrival time."""

    def __init__(self, pose: dict[str, float], log: CallLog) -> None:
        self.pose = {j: 0.0 for j in PEPPER_JOINTS} | pose
        self.calls = log
        self.lock = threading.Lock()

    def _check(self, names: list[str]) -> list[str]:
        names = [names] if isinstance(names, str) else list(names)
        for n in names:
            if n not in self.pose:
                raise RuntimeError(f"ALMotion: unknown joint {n!r}")
        return names

    def _log(self, entry: dict[str, Any]) -> None:
        self.calls.add(entry)

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
        return self.calls.json()


class CallLog:
    """The calls of every service, in the order they arrived."""

    def __init__(self) -> None:
        self.entries: list[dict[str, Any]] = []
        self.lock = threading.Lock()

    def add(self, entry: dict[str, Any]) -> None:
        with self.lock:
            self.entries.append(entry)

    def json(self) -> str:
        with self.lock:
            return json.dumps(self.entries)


class RecordingAudioDevice:
    """ALAudioDevice look-alike: takes remote PCM buffers; the first one starts the sound after
    `start_delay_s` (the output opening), and its call answers once the sound has started."""

    def __init__(self, log: CallLog, start_delay_s: float) -> None:
        self.calls = log
        self.start_delay_s = start_delay_s
        self.started: float | None = None
        self.lock = threading.Lock()

    def sendRemoteBufferToOutput(self, nbOfFrames: int, buffer: Any) -> bool:
        t = time.monotonic()
        data = bytes(buffer)
        if not 0 < nbOfFrames <= MAX_FRAMES or len(data) != 4 * nbOfFrames:
            raise RuntimeError(
                f"ALAudioDevice: {nbOfFrames} frames need {4 * nbOfFrames} bytes of 16-bit "
                f"stereo (got {len(data)}), at most {MAX_FRAMES} frames a call"
            )
        self.calls.add({"call": "sendRemoteBufferToOutput", "t": t, "frames": int(nbOfFrames)})
        with self.lock:  # buffers queue behind the first one, as on the robot
            if self.started is None:
                time.sleep(self.start_delay_s)
                self.started = time.monotonic()
                self.calls.add({"call": "audioStart", "t": self.started})
        return True

    def flushAudioOutputs(self) -> None:
        self.calls.add({"call": "flushAudioOutputs", "t": time.monotonic()})


def serve(lifetime_s: float, *, pose: dict[str, float], audio_delay_s: float = 0.0) -> None:
    import qi

    qi.logging.setLevel(qi.logging.ERROR)
    session = qi.Session()
    session.listenStandalone("tcp://127.0.0.1:0")
    log = CallLog()
    session.registerService("ALMotion", RecordingMotion(pose, log))

    class AudioDevice(RecordingAudioDevice):
        # NAOqi takes the buffer as binary; an untyped Python method would get its repr instead
        @qi.bind(qi.Bool, (qi.Int32, qi.Buffer))
        def sendRemoteBufferToOutput(self, nbOfFrames: int, buffer: Any) -> bool:
            return super().sendRemoteBufferToOutput(nbOfFrames, buffer)

    session.registerService("ALAudioDevice", AudioDevice(log, audio_delay_s))
    print(STARTED, session.endpoints()[0], flush=True)
    time.sleep(lifetime_s)  # bounded lifetime: never outlives a crashed test run for long
    session.close()


class NaoqiServer:
    """Starts `serve` in a subprocess; `url`, `calls()`, `kill()`; a context manager."""

    def __init__(
        self,
        pose: dict[str, float] | None = None,
        lifetime_s: float = 60.0,
        audio_delay_s: float = 0.0,
    ) -> None:
        args = ["--lifetime", str(lifetime_s), "--pose", json.dumps(pose or {})]
        args += ["--audio-delay", str(audio_delay_s)]
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
    parser.add_argument(
        "--audio-delay", type=float, default=0.0, help="seconds the audio output takes to start"
    )
    ns = parser.parse_args()
    serve(ns.lifetime, pose=json.loads(ns.pose), audio_delay_s=ns.audio_delay)
