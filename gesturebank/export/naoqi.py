"""Angles for `ALMotion.angleInterpolation(names, angleLists, timeLists, isAbsolute)`, the call
Choregraphe timelines and NAOqi scripts use: a JSON file of the four arguments, and a small
Python script that plays it on a robot with the `qi` SDK.

Times are seconds from the call; the first frame comes at `lead_s` (the move from wherever the
robot is). With speech (`audio`), the script plays it on the robot as `replay --backend naoqi
--audio` does (`gesturebank.robot.backends.naoqi`): streamed to ALAudioDevice, the motion after
frame 0 timed from the moment the robot reports its sound started.

Angles must already be finite, inside the limits and slow enough (`gesturebank.cli.export` makes
them so with the same safety as `gesturebank replay`).
"""

from __future__ import annotations

import io
import json
import os
import wave
from pathlib import Path

import numpy as np

from gesturebank.errors import InputError
from gesturebank.fileio import write_bytes_atomic
from gesturebank.robot.pepper import JOINTS

SCRIPT = '''\
"""Play {json_name} on Pepper: python {script_name} [tcp://ROBOT:9559] (needs the qi SDK).

With speech (the JSON's "audio", a 48 kHz 16-bit stereo WAV beside it), the robot plays it: the
sound is streamed to its ALAudioDevice, and the motion starts when the robot answers the first
buffer, that is when its sound has started, so both keep the robot's time.
"""
import io
import json
import os
import wave
import sys
import threading
import time
import wave

import qi

CHUNK = 4800  # frames a call: 0.1 s at 48 kHz (NAOqi takes at most 16384)
AHEAD_S = 0.3  # sound queued on the robot ahead of what it plays
now = getattr(time, "monotonic", time.time)

url = sys.argv[1] if len(sys.argv) > 1 else "tcp://127.0.0.1:9559"
here = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(here, "{json_name}")) as f:
    data = json.load(f)
app = qi.Application(["gesturebank-export", "--qi-url=" + url])
app.start()
motion = app.session.service("ALMotion")
motion.wakeUp()
names, angles, times = data["names"], data["angleLists"], data["timeLists"]
if not data.get("audio"):
    motion.angleInterpolation(names, angles, times, True)
    sys.exit(0)

# To the first pose (from wherever the robot is), then the speech, then the rest on its clock.
motion.angleInterpolation(names, [a[:1] for a in angles], [t[:1] for t in times], True)
device = app.session.service("ALAudioDevice")
sound = wave.open(os.path.join(here, data["audio"]), "rb")
pcm = sound.readframes(sound.getnframes())
started, failed, answered = [], [], threading.Event()


def stream():
    frames = len(pcm) // 4
    for first in range(0, frames, CHUNK):
        if started:  # keep AHEAD_S queued on the robot, not the whole file
            time.sleep(max(0.0, started[0] + first / 48000.0 - AHEAD_S - now()))
        n = min(CHUNK, frames - first)
        try:
            device.sendRemoteBufferToOutput(n, pcm[4 * first : 4 * (first + n)])
        except RuntimeError as exc:
            failed.append(exc)
            answered.set()
            return
        if not started:
            started.append(now())  # the robot answered: its sound has begun
            answered.set()


player = threading.Thread(target=stream)
player.start()
answered.wait()
if failed:
    sys.exit("ALAudioDevice could not play the speech: %s" % failed[0])
late = now() - started[0]
t0 = times[0][0]
keep = [k for k, t in enumerate(times[0]) if t - t0 > late]
if keep:
    rest = [[a[k] for k in keep] for a in angles]
    ahead = [[times[0][k] - t0 - late for k in keep]] * len(names)
    motion.angleInterpolation(names, rest, ahead, True)
player.join()
'''


def naoqi_arguments(
    *, times: np.ndarray, angles: np.ndarray, lead_s: float, profile: str, audio: str | None = None
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
        "audio": audio,  # the speech WAV's name beside the JSON, or None
    }


def write_naoqi(
    path: str | os.PathLike[str],
    *,
    times: np.ndarray,
    angles: np.ndarray,
    lead_s: float,
    profile: str,
    audio: str | os.PathLike[str] | None = None,
) -> tuple[Path, ...]:
    """Write `path` (.json) and the script beside it (.py), and with `audio` the speech as the
    robot plays it (.wav: 48 kHz 16-bit stereo); returns the paths written."""
    out = Path(path).with_suffix(".json")
    script = out.with_suffix(".py")
    sound = None if audio is None else write_robot_wav(audio, out.with_suffix(".wav"))
    args = naoqi_arguments(
        times=times,
        angles=angles,
        lead_s=lead_s,
        profile=profile,
        audio=None if sound is None else sound.name,
    )
    write_bytes_atomic(out, json.dumps(args).encode())
    text = SCRIPT.format(json_name=out.name, script_name=script.name)
    write_bytes_atomic(script, text.encode())
    return (out, script) if sound is None else (out, script, sound)


def write_robot_wav(audio: str | os.PathLike[str], path: Path) -> Path:
    """`audio`'s first track as ALAudioDevice plays it: a 48 kHz 16-bit stereo WAV at `path`."""
    from gesturebank.audio.io import read_audio
    from gesturebank.robot.backends.naoqi import SAMPLE_RATE, stereo_pcm

    track = read_audio(audio, sample_rate=SAMPLE_RATE)
    if track is None or not len(track.signal):
        raise InputError(f"{os.fspath(audio)}: no audio track to export")
    buffer = io.BytesIO()
    with wave.open(buffer, "wb") as w:
        w.setnchannels(2)
        w.setsampwidth(2)
        w.setframerate(SAMPLE_RATE)
        w.writeframes(stereo_pcm(track.signal))
    write_bytes_atomic(path, buffer.getvalue())
    return path
