"""Two-person test takes rendered from motion capture: a conversation in turns, and people who
do not speak with speech over them (issue 32's test media; rendered, never committed).

Both figures play the bvhtools test take side by side, each turned so its head faces the camera
on average (`facing_turns`), in a picture centred between them. In the turn-taking
take each speaks real speech (CMU ARCTIC from the samples) in turn on one audio track, and
its mouth opens with the envelope of its own speech, `MOUTH_LAG_S` late, with noise; the
listener's mouth moves now and then without speech. In the dubbed take the same speech plays
over the two figures, whose mouths stay shut.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.io import wavfile

from gesturebank.config import MocapConfig, SynthConfig
from gesturebank.footage import SPEECH_RATE
from gesturebank.mocap.bvh import read_bvh, write_bvh
from gesturebank.synth.camera import Stage, orbit_camera, stage_of
from gesturebank.synth.figure import head_frame
from gesturebank.synth.take import Performer, cached_render, place, stretch
from gesturebank.synth.truth import Truth
from gesturebank.testing.mocap import BVH

UTTERANCES = ("speech/arctic_a0007.wav", "speech/arctic_a0009.wav", "speech/arctic_a0009.wav")
GAP_S = 0.3  # silence between two turns
MOUTH_LAG_S = (0.12, 0.17)  # each figure's mouth behind its speech (issue: 80-200 ms)
# The bvhtools take walks about; from 15.8 s its head stays within 30° of one direction for 93 %
# of 11 s. The figures play it on the spot (`standing_bvh`), so both stay in the picture.
START_S = 15.8
MOUTH_SEED = 0  # the mouths' noise
SEPARATION_M = 0.9  # between the two figures
# 1280 × 720 at 2 m (50° vertical field of view): faces about 58 px wide, above the mouth
# measurement's 48 px; 15 fps keeps the render and the build short.
CONFIG = SynthConfig(
    width_px=1280,
    height_px=720,
    distance_m=1.4,
    rate_fps=15.0,
    start_s=START_S,
    look="tshirt",
    supersample=1,
)


@dataclass(frozen=True)
class Conversation:
    """A rendered two-person take: its truth and video, and who speaks when.

    turns: (start_s, end_s, figure) per utterance on the video's clock; figure 0 stands on the
    left of the picture, figure 1 on the right."""

    truth: Truth
    video: Path
    turns: tuple[tuple[float, float, int], ...]

    def speaker_at(self, t: np.ndarray) -> np.ndarray:
        """(N,) the figure speaking at each of times `t` (-1: between turns)."""
        out = np.full(len(t), -1)
        for a, b, who in self.turns:
            out[(t >= a) & (t < b)] = who
        return out


def _read(path: Path) -> np.ndarray:
    rate, x = wavfile.read(path)
    if rate != SPEECH_RATE or x.ndim != 1:
        raise ValueError(f"{path}: expected {SPEECH_RATE} Hz mono")
    return x.astype(np.float64) / 32768.0


def speech_track(samples: Path) -> tuple[np.ndarray, tuple[tuple[float, float, int], ...]]:
    """The utterances one after the other, GAP_S apart, alternating figures 0, 1, 0, ..."""
    parts: list[np.ndarray] = []
    turns = []
    t = 0.0
    gap = np.zeros(round(GAP_S * SPEECH_RATE))
    for k, rel in enumerate(UTTERANCES):
        x = _read(samples / rel)
        turns.append((t, t + len(x) / SPEECH_RATE, k % 2))
        parts += [x, gap]
        t += (len(x) + len(gap)) / SPEECH_RATE
    return np.concatenate(parts), tuple(turns)


def envelope(signal: np.ndarray, *, times: np.ndarray, window_s: float = 0.06) -> np.ndarray:
    """RMS of `signal` (SPEECH_RATE Hz) in `window_s` windows centred on `times` (s)."""
    half = round(window_s * SPEECH_RATE / 2)
    out = np.zeros(len(times))
    for i, t in enumerate(times):
        c = round(t * SPEECH_RATE)
        part = signal[max(0, c - half) : max(0, c + half)]
        out[i] = np.sqrt(np.mean(part * part)) if len(part) else 0.0
    return out


def mouths(
    signal: np.ndarray, turns: tuple[tuple[float, float, int], ...], *, times: np.ndarray, seed: int
) -> np.ndarray:
    """(2, T) mouth openings in [0, 1] at the video's `times`: each figure's follows the envelope
    of its own turns MOUTH_LAG_S[figure] late, with noise; while the other speaks it moves a
    little now and then (one 0.4 s bump per second or two), not with the speech."""
    rng = np.random.default_rng(seed)
    out = np.zeros((2, len(times)))
    for who in (0, 1):
        own = np.zeros_like(signal)
        for a, b, w in turns:
            if w == who:
                sl = slice(round(a * SPEECH_RATE), round(b * SPEECH_RATE))
                own[sl] = signal[sl]
        env = envelope(own, times=times - MOUTH_LAG_S[who])
        scale = np.percentile(env[env > 0], 95) if (env > 0).any() else 1.0
        out[who] = 0.9 * env / scale + rng.normal(0, 0.04, len(times))
        for a, b, w in turns:
            if w != who:  # the listener: a bump of 0.4 s now and then
                for start in np.arange(a + rng.uniform(0.3, 1.0), b - 0.5, rng.uniform(1.2, 2.0)):
                    bump = (times >= start) & (times < start + 0.4)
                    out[who, bump] += 0.35 * np.sin(np.pi * (times[bump] - start) / 0.4)
    return np.clip(out, 0, 1)


def standing_bvh(samples: Path, folder: Path) -> Path:
    """`folder/standing.bvh`: the bvhtools take with its root held over its first position (its
    root's X and Z position channels constant; the height and every rotation as recorded)."""
    motion = read_bvh(samples / BVH)
    root = motion.names[motion.parents.index(-1)]
    cols = motion.columns(root)
    chans = motion.channels[motion.index[root]]
    values = motion.values.copy()
    for k, name in enumerate(chans):
        if name in ("Xposition", "Zposition"):
            values[:, cols.start + k] = values[0, cols.start + k]
    out = folder / "standing.bvh"
    text_motion = type(motion)(
        motion.names,
        motion.parents,
        motion.offsets,
        motion.channels,
        motion.end_site,
        values,
        motion.frame_time,
    )
    write_bvh(out, text_motion)
    return out


def facing_turns(bvh: Path, *, config: SynthConfig, mocap: MocapConfig) -> list[float]:
    """Each figure's turn (degrees, towards its left) that points its head, on average over the
    take, at the camera. The take's head looks about 15° to one side, and the figure on that side
    is seen 18° further round: untouched, that face is turned 30-45° from the camera, where the
    face landmark model finds it in few frames (presence < 0.5 in 19 of 21 measured)."""
    _, joints = stretch(bvh, config=config, mocap=mocap)
    stage = stage_of(joints)
    sides = [place(joints, stage=stage, offset_m=_offset(side), turn_deg=0.0) for side in SIDES]
    centre = Stage(stage_of(np.concatenate(sides, 0)).target, stage.forward, stage.up)
    camera = orbit_camera(
        centre,
        name="c",
        azimuth_deg=config.azimuths_deg[0],
        elevation_deg=config.elevation_deg,
        distance_m=config.distance_m,
        fov_deg=config.fov_deg,
        size=(config.width_px, config.height_px),
    )
    turns = []
    for placed in sides:
        head, axes = head_frame(placed)
        forward, to_camera = axes[:, 0], camera.center - head
        # signed angle about the vertical from the head's forward to the camera (Rodrigues' sign)
        cross = np.cross(forward, to_camera) @ stage.up
        turns.append(float(np.degrees(np.median(np.arctan2(cross, (forward * to_camera).sum(1))))))
    return turns


SIDES = (-1.0, 1.0)  # figure 0 on the picture's left


def _offset(side: float) -> tuple[float, float, float]:
    return (0.0, side * SEPARATION_M / 2, 0.0)


def _render(
    samples: Path, cache: Path, *, mouth: np.ndarray | None, signal: np.ndarray, name: str
) -> Truth:
    folder = cache / "conversation"
    folder.mkdir(parents=True, exist_ok=True)
    wav = folder / f"{name}.wav"
    data = np.round(np.clip(signal, -1, 1) * 32767).astype(np.int16)
    if not wav.is_file() or wavfile.read(wav)[1].tobytes() != data.tobytes():
        wavfile.write(wav, SPEECH_RATE, data)
    config = CONFIG.model_copy(update={"length_s": len(signal) / SPEECH_RATE})
    bvh = standing_bvh(samples, folder)
    turns = facing_turns(bvh, config=config, mocap=MocapConfig())
    performers = [
        Performer(
            bvh,
            offset_m=_offset(side),
            turn_deg=turns[k],
            mouth=None if mouth is None else mouth[k],
            look="tshirt" if k == 0 else "sleeves",
        )
        for k, side in enumerate(SIDES)
    ]
    return cached_render(performers, config=config, mocap=MocapConfig(), speech=[wav], cache=cache)


def video_times(signal: np.ndarray) -> np.ndarray:
    """The render's frame times for a speech track `signal`."""
    count = int(np.floor(len(signal) / SPEECH_RATE * CONFIG.rate_fps + 1e-6))
    return np.arange(count) / CONFIG.rate_fps


def turn_taking(samples: Path, cache: Path) -> Conversation:
    """The turn-taking take, rendered into `cache` once (`synth.take.cached_render`)."""
    signal, turns = speech_track(samples)
    opening = mouths(signal, turns, times=video_times(signal), seed=MOUTH_SEED)
    truth = _render(samples, cache, mouth=opening, signal=signal, name="turns")
    return Conversation(truth, truth.videos[0], turns)


def dubbed(samples: Path, cache: Path) -> Conversation:
    """The two figures with shut mouths and the same speech over them: nobody speaks."""
    signal, _ = speech_track(samples)
    truth = _render(samples, cache, mouth=None, signal=signal, name="turns")
    return Conversation(truth, truth.videos[0], ())
