"""Offline playback sync: stream (Eq. 4.1, η = 0.95 and 1.0) vs one angleInterpolation call.

Plays a 5 s, 100 Hz timeline through the unmodified `naoqi` backend against the recording
ALMotion of gesturebank/testing/naoqi_server.py (a qi session in another process, over TCP) and
measures, on the server's clock, when each frame arrived relative to when it was due
(t0 + times[i]).
For `interpolate` there is one call: its arrival offset applies to every frame (the robot's own
execution of the keyframes is not modelled by the stand-in).
Run: .venv/bin/python benchmarks/playback.py [--quick]

--quick: a 1 s timeline instead of 5 s (a few seconds), to check that the script runs.
"""

from __future__ import annotations

import argparse

import numpy as np
from rich.console import Console
from rich.table import Table

from gesturebank.config import PlaybackConfig
from gesturebank.robot import pepper
from gesturebank.robot.backends.naoqi import NaoqiBackend
from gesturebank.robot.playback import play
from gesturebank.robot.timeline import Timeline
from gesturebank.testing.naoqi_server import NaoqiServer


def timeline(seconds: float = 5.0) -> Timeline:
    t = np.arange(int(seconds * 100)) * 0.01
    a = np.tile(pepper.neutral_pose(), (len(t), 1))
    a[:, 3] -= 0.8 * np.sin(2 * np.pi * 0.5 * t)
    a[:, 7] -= 0.8 * np.sin(2 * np.pi * 0.7 * t)
    return Timeline.of(t, a)


def run(mode: str, eta: float, seconds: float) -> tuple[float, float, float]:
    tl = timeline(seconds)
    cfg = PlaybackConfig(mode=mode, eta=eta, start_s=0.5, return_s=0.5)  # type: ignore[arg-type]
    with NaoqiServer(lifetime_s=60) as srv:
        backend = NaoqiBackend(srv.url)
        result = play(tl, backend, config=cfg)
        backend.close()
        calls = srv.calls()
    if mode == "stream":
        sets = [c["t"] for c in calls if c["call"] == "setAngles"]
        arrival = np.array(sets[result.n_start : result.n_start + len(tl)])
        err = (arrival - (result.t0 + tl.times)) * 1000
    else:
        interp = [c["t"] for c in calls if c["call"] == "angleInterpolation"]
        err = np.full(len(tl), (interp[1] - (result.t0 + tl.times[0])) * 1000)
    p50, p99 = np.percentile(np.abs(err), [50, 99])
    return float(p50), float(p99), float(np.mean(err))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a 1 s timeline")
    args = parser.parse_args()
    seconds = 1.0 if args.quick else 5.0
    table = Table(title=f"Offline sync: arrival − due time per frame, {seconds:g} s at 100 Hz")
    for col in ("mode", "|err| p50 ms", "|err| p99 ms", "mean err ms"):
        table.add_column(col, justify="left" if col == "mode" else "right")
    for mode, eta in (("stream", 0.95), ("stream", 1.0), ("interpolate", 1.0)):
        label = f"{mode} (η = {eta})" if mode == "stream" else "interpolate (one call)"
        p50, p99, mean = run(mode, eta, seconds)
        table.add_row(label, f"{p50:.2f}", f"{p99:.2f}", f"{mean:.2f}")
    Console(width=max(Console().width, 100)).print(table)


if __name__ == "__main__":
    main()
