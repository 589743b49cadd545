"""Write rendered frames as they come (a 20 s take at 1280×720 does not fit in memory as a
`footage.Frames`): the same encoder, pixel format, timestamps and AAC speech as
`footage.write`, atomically."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable
from fractions import Fraction
from pathlib import Path

import av
import numpy as np

from gesturebank.fileio import permissions
from gesturebank.footage import ENCODER, SPEECH_RATE


def write_stream(
    images: Iterable[np.ndarray],
    out: Path,
    *,
    size: tuple[int, int],
    fps: Fraction,
    count: int,
    speech: np.ndarray,
) -> Path:
    """Encode `count` (H, W, 3) uint8 RGB `images` of `size` = (W, H) (pts = index, time base
    1 / fps) with `speech` (16 kHz mono float32, trimmed or zero-padded to the video) as AAC."""
    w, h = size
    n_audio = round(count / fps * SPEECH_RATE)
    audio = np.pad(speech[:n_audio], (0, max(0, n_audio - len(speech)))).astype(np.float32)
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(dir=out.parent, prefix=f".{out.stem}.", suffix=out.suffix)
    os.close(fd)
    tmp = Path(name)
    written = 0
    try:
        with av.open(str(tmp), "w") as dst:
            video = dst.add_stream("libx264", rate=fps)
            video.width, video.height, video.pix_fmt = w, h, "yuv420p"
            video.options = dict(ENCODER)
            sound = dst.add_stream("aac", rate=SPEECH_RATE, layout="mono")
            hop, sent = 1024, 0
            for i, img in enumerate(images):
                if img.shape != (h, w, 3) or img.dtype != np.uint8:
                    raise ValueError(
                        f"{out}: frame {i} is {img.shape} {img.dtype}, not {h}×{w}×3 uint8"
                    )
                frame = av.VideoFrame.from_ndarray(img, format="rgb24")
                frame.pts, frame.time_base = i, 1 / fps
                dst.mux(video.encode(frame))
                written += 1
                until = min(n_audio, round((i + 1) / fps * SPEECH_RATE))
                while sent < until:  # audio up to the end of this frame: streams interleave
                    chunk = np.ascontiguousarray(audio[sent : sent + hop].reshape(1, -1))
                    block = av.AudioFrame.from_ndarray(chunk, "fltp", "mono")
                    block.sample_rate, block.pts = SPEECH_RATE, sent
                    dst.mux(sound.encode(block))
                    sent += chunk.shape[1]
            dst.mux(video.encode(None))
            dst.mux(sound.encode(None))
        if written != count:
            raise ValueError(f"{out}: {written} frames written, {count} expected")
        os.chmod(tmp, permissions())  # mkstemp makes it private
        os.replace(tmp, out)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return out
