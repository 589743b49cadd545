"""Real footage of the kinds users bring, derived from the sample media (`fetch-samples`):
the talking demos of `fetch-samples`, and the takes the tests and benchmarks build.

The sample clips are short (Pose2Sim: 100 frames) and carry no speech. Here they are made into
takes that look like what users film: ping-ponged (forward, backward, forward … so the
motion never jumps) to any length, at 60 or 30 fps, cropped waist-up, cut from one camera to
another, at low resolution, each with real speech (the two CMU ARCTIC sentences, looped) as
its audio track.

Frames are transformed in memory (`Frames`, pure functions) and written once by `write`
(libx264, yuv420p, pts = frame index at the clip's rate, AAC speech), atomically.
`make_footage` builds the standard set (`standard()`: recipes as data) and skips a take whose
file and recipe are unchanged (a JSON beside each file records the recipe and the inputs' sha256).
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable, Collection, Sequence
from dataclasses import asdict, dataclass, replace
from fractions import Fraction
from pathlib import Path

import av
import numpy as np

from gesturebank.fileio import sha256_file, write_bytes_atomic

PathLike = str | os.PathLike[str]

CAM01 = "pose2sim/Demo_SinglePerson/videos/cam01.mp4"
CAM03 = "pose2sim/Demo_SinglePerson/videos/cam03.mp4"
SPORTS2D = "sports2d/Demo/demo.mp4"
# cam02 (portrait, 1080 × 1920) sees the man from the front, his face blurred by the demo's
# authors, and a woman standing far behind him (her shoulders about a quarter of his wide).
CAM02 = "pose2sim/Demo_SinglePerson/videos/cam02.mp4"
# Waist-up around him, his hips out of frame (head ≈ y 450–550, hips ≈ y 850 in the source,
# the arms sweep x 400–1000), the woman inside it right of him: 720 × 480, 3:2 (issue 41).
BEHIND_BOX = (240, 330, 960, 810)
# cam04 sees both people from the front (in cam01 the second person, nearer, has her back to it)
MULTI_CAM = "pose2sim/Demo_MultiPerson/videos/cam04.mp4"
SPEECH = ("speech/arctic_a0007.wav", "speech/arctic_a0009.wav")

SPEECH_RATE = 16000
# libx264 options (yuv420p, the format every player and decoder takes); part of every take's
# cache key. CRF 18 is visually lossless for x264; veryfast encodes 1080×1920 at ~30 ms a frame.
ENCODER = {"preset": "veryfast", "crf": "18"}
# Bump when a transform changes what it makes (invalidates every cached take).
VERSION = 1

# Cam01 from the head to the hips, chosen on every 10th frame and checked with BlazePose on all
# 100: eyes at y ≥ 424 (head top ≈ 330), wrists at y ≥ 401, hips at y ≤ 882, the upper body at
# 257 ≤ x ≤ 1035 as the arms sweep: so full width, and ~80 px spare above the head and below
# the hips. 1080 × 720 (3:2), a typical waist-up framing.
WAIST_UP_BOX = (0, 240, 1080, 960)


@dataclass(frozen=True)
class Frames:
    """A clip in memory at a constant frame rate.

    images: (H, W, 3) uint8 RGB frames, all of one size. An image may appear several times (a
            ping-pong repeats its source's frames by reference, so length costs no memory).
    fps:    frames per second, exact.
    """

    images: tuple[np.ndarray, ...]
    fps: Fraction

    def __post_init__(self) -> None:
        if not self.images:
            raise ValueError("Frames: no images")
        first = self.images[0]
        if first.ndim != 3 or first.shape[2] != 3:
            raise ValueError(f"Frames: images must be (H, W, 3), got {first.shape}")
        if any(img.shape != first.shape or img.dtype != np.uint8 for img in self.images):
            raise ValueError(f"Frames: every image must be {first.shape} uint8")
        if self.fps <= 0:
            raise ValueError(f"Frames: fps must be positive, got {self.fps}")
        object.__setattr__(self, "fps", Fraction(self.fps))

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) px."""
        h, w = self.images[0].shape[:2]
        return w, h

    @property
    def duration_s(self) -> float:
        return len(self.images) / float(self.fps)


def load(path: PathLike, *, seconds: float | None = None) -> Frames:
    """The frames of a (short) video at the stream's average rate: all of them, or only as many
    as `seconds` needs (a ping-pong shorter than the clip plays only its start)."""
    with av.open(os.fspath(path)) as container:
        stream = container.streams.video[0]
        rate = stream.average_rate or stream.guessed_rate
        if not rate:
            raise ValueError(f"{path}: video stream has no frame rate")
        wanted = None if seconds is None else max(1, round(seconds * rate))
        images: list[np.ndarray] = []
        for frame in container.decode(stream):
            images.append(frame.to_ndarray(format="rgb24"))
            if wanted is not None and len(images) >= wanted:
                break
    if not images:
        raise ValueError(f"{path}: no frames")
    return Frames(tuple(images), Fraction(rate))


def ping_pong(frames: Frames, *, seconds: float) -> Frames:
    """`seconds` of the clip played forward, backward, forward … Turning points are not repeated
    (0 … n-1, n-2 … 1, 0 …), so every step is one real frame of motion."""
    n = len(frames.images)
    period = list(range(n)) + list(range(n - 2, 0, -1))
    count = round(seconds * frames.fps)
    if count < 1:
        raise ValueError(f"ping_pong: {seconds} s is less than one frame at {frames.fps} fps")
    return replace(
        frames, images=tuple(frames.images[period[i % len(period)]] for i in range(count))
    )


def concat(parts: Sequence[Frames]) -> Frames:
    """The clips one after the other (hard cuts); they must share size and rate."""
    first = parts[0]
    for part in parts[1:]:
        if part.size != first.size or part.fps != first.fps:
            raise ValueError(
                f"concat: {part.size} at {part.fps} fps does not match {first.size} at {first.fps}"
            )
    return replace(first, images=tuple(img for part in parts for img in part.images))


def _per_image(frames: Frames, fn: Callable[[np.ndarray], np.ndarray]) -> Frames:
    """`fn` applied once per distinct image (repeats of an image stay shared)."""
    done: dict[int, np.ndarray] = {}
    out = []
    for img in frames.images:
        if id(img) not in done:
            done[id(img)] = fn(img)
        out.append(done[id(img)])
    return replace(frames, images=tuple(out))


def crop(frames: Frames, *, box: tuple[int, int, int, int]) -> Frames:
    """The region box = (x0, y0, x1, y1) px (x1, y1 excluded) of every frame."""
    x0, y0, x1, y1 = box
    w, h = frames.size
    if not (0 <= x0 < x1 <= w and 0 <= y0 < y1 <= h):
        raise ValueError(f"crop: box {box} is not inside the {w}×{h} frame")
    return _per_image(frames, lambda img: np.ascontiguousarray(img[y0:y1, x0:x1]))


def rescale(
    frames: Frames, *, height: int | None = None, size: tuple[int, int] | None = None
) -> Frames:
    """Frames resized to `size` = (width, height), or to `height` with the aspect kept (width
    rounded to an even number, as yuv420p needs). Area averaging when shrinking."""
    import cv2

    w, h = frames.size
    if size is None:
        if height is None:
            raise ValueError("rescale: give height or size")
        size = (max(2, 2 * round(w * height / h / 2)), height)
    if size == (w, h):
        return frames
    shrink = size[0] * size[1] < w * h
    interpolation = cv2.INTER_AREA if shrink else cv2.INTER_LINEAR
    return _per_image(frames, lambda img: cv2.resize(img, size, interpolation=interpolation))


def keep_every(frames: Frames, *, k: int) -> Frames:
    """Every k-th frame (the first kept) at rate fps / k: the same motion at a lower rate."""
    if k < 1:
        raise ValueError(f"keep_every: k must be ≥ 1, got {k}")
    return Frames(frames.images[::k], frames.fps / k)


def looped_speech(paths: Sequence[PathLike], *, seconds: float) -> np.ndarray:
    """(round(seconds · 16000),) float32 in [-1, 1]: the files one after the other, repeated."""
    from scipy.io import wavfile

    parts = []
    for p in paths:
        rate, data = wavfile.read(os.fspath(p))
        if rate != SPEECH_RATE or data.ndim != 1 or data.dtype != np.int16:
            raise ValueError(f"{p}: expected 16 kHz mono 16-bit speech, got {rate} Hz {data.shape}")
        parts.append(data.astype(np.float32) / 32768.0)
    one = np.concatenate(parts)
    n = round(seconds * SPEECH_RATE)
    return np.tile(one, -(-n // len(one)))[:n]


def write(frames: Frames, out: PathLike, *, speech: np.ndarray, audio_delay_s: float = 0.0) -> Path:
    """Encode the frames (pts = index, time base 1 / fps) with `speech` (16 kHz mono float32,
    trimmed or zero-padded to the video's duration) as AAC; the file appears atomically.
    audio_delay_s: the audio track starts this late (its first sample's pts), as in footage
    whose sound was recorded apart and muxed late; the speech then ends with the video."""
    w, h = frames.size
    if w % 2 or h % 2:
        raise ValueError(f"{out}: yuv420p needs an even frame size, got {w}×{h}")
    if not 0.0 <= audio_delay_s < frames.duration_s:
        raise ValueError(f"{out}: audio_delay_s {audio_delay_s} is outside the video")
    offset = round(audio_delay_s * SPEECH_RATE)  # samples of the video before the audio
    n_audio = round(frames.duration_s * SPEECH_RATE) - offset
    audio = np.pad(speech[:n_audio], (0, max(0, n_audio - len(speech)))).astype(np.float32)
    final = Path(out)
    final.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(dir=final.parent, prefix=f".{final.stem}.", suffix=final.suffix)
    os.close(fd)
    tmp = Path(name)  # hidden, and with the suffix that tells FFmpeg the container
    try:
        with av.open(str(tmp), "w") as dst:
            video = dst.add_stream("libx264", rate=frames.fps)
            video.width, video.height, video.pix_fmt = w, h, "yuv420p"
            video.options = dict(ENCODER)
            sound = dst.add_stream("aac", rate=SPEECH_RATE, layout="mono")
            hop, sent = 1024, 0
            for i, img in enumerate(frames.images):
                frame = av.VideoFrame.from_ndarray(img, format="rgb24")
                frame.pts, frame.time_base = i, 1 / frames.fps
                dst.mux(video.encode(frame))
                # Audio up to the end of this frame, so the two streams stay interleaved.
                until = min(n_audio, round((i + 1) / frames.fps * SPEECH_RATE) - offset)
                while sent < until:
                    chunk = audio[sent : sent + hop].reshape(1, -1)
                    block = av.AudioFrame.from_ndarray(np.ascontiguousarray(chunk), "fltp", "mono")
                    block.sample_rate, block.pts = SPEECH_RATE, offset + sent
                    dst.mux(sound.encode(block))
                    sent += chunk.shape[1]
            dst.mux(video.encode(None))
            dst.mux(sound.encode(None))
        os.replace(tmp, final)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return final


@dataclass(frozen=True)
class Recipe:
    """One derived take, as data (its fields are part of the cache key).

    sources: sample clips (paths under the samples folder), played one after the other; a later
             one is first resized to the first one's frame size (cam03 is 1088 px wide, cam01
             1080).
    seconds: ping-pong each source to this length (one entry per source); None: as it is.
    box:     crop (x0, y0, x1, y1) px applied to every source.
    height:  rescale to this height, aspect kept.
    keep:    keep every keep-th frame (rate / keep).
    """

    sources: tuple[str, ...]
    seconds: tuple[float, ...] | None = None
    box: tuple[int, int, int, int] | None = None
    height: int | None = None
    keep: int = 1


# A 10-minute talk with one camera change half-way, 30 fps, 360 px high: long enough to be
# detected in chunks (build.chunk_s); tests shorten it (`replace(LECTURE, seconds=...)`).
LECTURE = Recipe((CAM01, CAM03), (300.0, 300.0), height=360, keep=2)


def standard(*, time_scale: float = 1.0) -> dict[str, Recipe]:
    """The standard set. time_scale shortens every take (tests use a few hundredths)."""

    def s(*seconds: float) -> tuple[float, ...]:
        return tuple(round(x * time_scale, 6) for x in seconds)

    return {
        "long60": Recipe((CAM01,), s(60)),
        "fps60": Recipe((CAM01,), s(10)),
        "fps30": Recipe((CAM01,), s(10), keep=2),
        "waist_up": Recipe((CAM01,), s(10), box=WAIST_UP_BOX),
        # a waist-up speaker, face blurred, with a much smaller person behind (speech dubbed)
        "behind": Recipe((CAM02,), s(10), box=BEHIND_BOX),
        "cut": Recipe((CAM01, CAM03), s(5, 5)),
        # Its whole 230 frames at 30 fps (a ping-pong as long as the clip is the clip).
        "crossing": Recipe((SPORTS2D,), s(23 / 3)),
        "lowres": Recipe((CAM01,), s(10), height=360),
        "multi": Recipe((MULTI_CAM,), s(10)),
    }


def build(recipe: Recipe, *, samples: Path) -> Frames:
    """The frames of a recipe (in memory)."""
    parts: list[Frames] = []
    first_size: tuple[int, int] | None = None
    for i, rel in enumerate(recipe.sources):
        clip = load(samples / rel, seconds=None if recipe.seconds is None else recipe.seconds[i])
        first_size = first_size or clip.size
        clip = rescale(clip, size=first_size)
        if recipe.box is not None:
            clip = crop(clip, box=recipe.box)
        if recipe.height is not None:
            clip = rescale(clip, height=recipe.height)
        if recipe.seconds is not None:
            clip = ping_pong(clip, seconds=recipe.seconds[i])
        parts.append(clip)
    return keep_every(concat(parts), k=recipe.keep)


def make_take(recipe: Recipe, *, samples: Path, out: Path) -> bool:
    """Write the take `out` (+ `out`.json) unless both exist for this recipe and these inputs.
    Returns whether it was written."""
    key = {
        "version": VERSION,
        "encoder": ENCODER,
        "recipe": asdict(recipe),
        "inputs": {rel: sha256_file(samples / rel) for rel in (*recipe.sources, *SPEECH)},
    }
    meta = out.with_suffix(".json")
    try:
        if out.is_file() and json.loads(meta.read_text()) == json.loads(json.dumps(key)):
            return False
    except (OSError, ValueError):
        pass
    meta.unlink(missing_ok=True)  # a take killed mid-write must not look finished
    frames = build(recipe, samples=samples)
    write(
        frames, out, speech=looped_speech([samples / p for p in SPEECH], seconds=frames.duration_s)
    )
    write_bytes_atomic(meta, json.dumps(key, indent=1).encode())
    return True


def make_footage(
    samples: Path,
    out: Path,
    *,
    time_scale: float = 1.0,
    names: Collection[str] | None = None,
) -> dict[str, Path]:
    """Build the standard set (or its takes `names`) into `out` (name → `out/<name>.mp4`),
    skipping takes already made with the same recipe and inputs, and takes whose sample clip is
    absent (`multi` needs pose2sim/Demo_MultiPerson)."""
    made: dict[str, Path] = {}
    for name, recipe in standard(time_scale=time_scale).items():
        if names is not None and name not in names:
            continue
        if not all((samples / rel).is_file() for rel in recipe.sources):
            continue
        path = out / f"{name}.mp4"
        make_take(recipe, samples=samples, out=path)
        made[name] = path
    return made
