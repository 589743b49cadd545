"""Audio out, started in step with a robot's playback: on this computer's default output device,
or on the robot itself (a backend that has a `speaker`, e.g. naoqi's ALAudioDevice)."""

from __future__ import annotations

import os
from typing import Protocol, runtime_checkable

from gesturebank.errors import RobotError

PathLike = str | os.PathLike[str]

# sounddevice loads the system's PortAudio at import; without it the import raises OSError
PORTAUDIO_HINT = "install the PortAudio library: apt-get install libportaudio2"


class AudioOut(Protocol):
    def start(self) -> float | None:
        """Start the sound; returns the time.monotonic() at which it started where the device
        reports it (playback then times the motion from it), else None (it starts now)."""
        ...

    def stop(self) -> None: ...


@runtime_checkable
class Speaking(Protocol):
    """A backend that plays the audio itself, on the robot (None: it was given none)."""

    @property
    def speaker(self) -> AudioOut | None: ...


class DeviceAudio:
    """Plays an audio file on this computer's default output (as the dissertation did)."""

    def __init__(self, path: PathLike, sample_rate: int = 48000) -> None:
        from gesturebank.audio.io import read_audio

        name = os.fspath(path)
        track = read_audio(path, sample_rate=sample_rate)
        if track is None:
            raise RobotError(f"{name}: no audio track to play")
        self.signal, self.rate = track.signal, track.sample_rate
        try:
            import sounddevice

            sounddevice.check_output_settings(samplerate=self.rate, channels=1)
        except Exception as exc:  # OSError: no PortAudio; PortAudioError: no device
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            hint = f"; {PORTAUDIO_HINT}" if "PortAudio library" in reason else ""
            raise RobotError(
                f"{name}: cannot play audio here: no output device ({reason}){hint}"
            ) from None
        self._sd = sounddevice

    def start(self) -> None:
        self._sd.play(self.signal, self.rate)  # no report of the start: motion runs from now

    def stop(self) -> None:
        self._sd.stop()
