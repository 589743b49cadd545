"""`gesturebank preview`: a clip's speaker beside the robot doing the same thing, with the audio.

Left half: the clip's span of its source video, cropped to the speaker (the box of their 2D
keypoints over the clip) with the keypoints drawn. Right half: the robot as `replay --clip
--backend sim` shows the clip without its safety moves (the angles clamped and speed-limited, at
their own times). One clock: output frame k shows clip time k / fps on both halves — the last
source frame at or before `start_s + k / fps` and the last robot command at or before `k / fps`.
The audio is the source's own track from the clip's start, cut to the clip's duration.

Each half carries a frame code in its bottom-left corner: a row of black or white squares, a
binary number (most significant bit first) naming the frame it shows — on the left the index of
the source video frame (counted from the file's first frame), on the right the index of the
clip's 100 Hz frame — with its legend written beside it ("< video frame 123").
`read_frame_code` reads it back, so a test (or a sceptical researcher) can check that both
halves show the same moment.
"""

from __future__ import annotations

import difflib
import logging
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import av
import cv2
import numpy as np

from gesturebank.clip import Clip
from gesturebank.config import PlaybackConfig, RenderConfig, VideoConfig
from gesturebank.errors import InputError
from gesturebank.fileio import atomic_open
from gesturebank.robot import pepper

log = logging.getLogger(__name__)

PathLike = str | os.PathLike[str]
CODE_BITS = 24  # frame indices below 2**24: 77 h of 60 fps video
_MARGIN = 0.12  # of the keypoints' box height, added on every side: the top of the head, the hands
_BACKGROUND = (40, 40, 40)  # RGB, around a crop that does not fill its half
BONE, _JOINT, _TEXT = (255, 200, 0), (255, 80, 40), (20, 20, 20)  # RGB; BONE: tests find it


# --------------------------------------------------------------------------------------------------
# Finding the clip


def suggest(wanted: str, known: list[str], *, what: str = "clip") -> str:
    """' — did you mean a, b?' naming the ids of `known` nearest to `wanted` ('' for none)."""
    prefixed = [k for k in known if k.startswith(wanted)]
    close = prefixed[:3] or difflib.get_close_matches(wanted, known, n=3, cutoff=0.5)
    return f" — did you mean {', '.join(close)}?" if close else f" ({len(known)} {what}s known)"


def take_clips(dataset: PathLike, take_id: str) -> list[str]:
    """The ids of a take's clips with arrays, in time order; InputError with the nearest takes."""
    from gesturebank import datasets

    ds = datasets.open(dataset)
    rows = ds.clips(None)
    ids = [
        r.clip.clip_id
        for r in sorted(rows, key=lambda r: r.clip.start_s)
        if r.take.take_id == take_id
    ]
    if not ids:
        takes = sorted({r.take.take_id for r in ds.rows()})
        raise InputError(
            f"{dataset}: no take {take_id!r} with clips{suggest(take_id, takes, what='take')}"
        )
    return ids


@dataclass(frozen=True)
class ClipSource:
    """A clip with what preview needs besides its arrays: its source video and QC status."""

    clip: Clip
    video: Path
    status: str
    reasons: tuple[str, ...]


def clip_source(dataset: PathLike, clip_id: str) -> ClipSource:
    """The clip `clip_id` of `dataset` and its source video; InputError (one line) naming the
    nearest clip ids for an unknown one, or the missing video."""
    from gesturebank import datasets

    ds = datasets.open(dataset)
    row = next((r for r in ds.clips(None) if r.clip.clip_id == clip_id), None)
    if row is None:
        known = ds.clip_ids(None)
        raise InputError(f"{dataset}: no clip {clip_id!r}{suggest(clip_id, known)}")
    video = Path(ds.info.videos_dir) / row.take.source  # sources: relative to the videos folder
    if not video.is_file():
        raise InputError(f"{video}: the source video of clip {clip_id} is gone")
    return ClipSource(ds.load(clip_id), video, row.clip.qc_status, row.clip.qc_reasons)


# --------------------------------------------------------------------------------------------------
# Pure pieces: the crop, the frame code


def crop_box(
    xy: np.ndarray, *, image_size: tuple[int, int], aspect: float
) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) px: the box of the finite points `xy (..., 2)` plus a margin, widened or
    heightened towards `aspect` (width / height) where the image allows, inside the image.
    The whole image when no point is finite."""
    width, height = image_size
    pts = np.asarray(xy, np.float64).reshape(-1, 2)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if not len(pts):
        return 0, 0, width, height
    (x0, y0), (x1, y1) = np.percentile(pts, 1, axis=0), np.percentile(pts, 99, axis=0)
    pad = _MARGIN * max(y1 - y0, x1 - x0, 0.2 * height)  # a lone point still gets a box
    x0, x1, y0, y1 = x0 - pad, x1 + pad, y0 - pad, y1 + pad
    w, h = x1 - x0, y1 - y0
    w, h = max(w, aspect * h), max(h, w / aspect)  # grow the short side to the aspect
    w, h = min(w, width), min(h, height)
    cx = np.clip((x0 + x1) / 2, w / 2, width - w / 2)
    cy = np.clip((y0 + y1) / 2, h / 2, height - h / 2)
    return (
        round(float(cx - w / 2)),
        round(float(cy - h / 2)),
        round(float(cx + w / 2)),
        round(float(cy + h / 2)),
    )


def _code_square(height: int, width: int) -> int:
    """Side of one square, px: the code spans at most half the panel's width."""
    return max(2, min(height // 30, width // (2 * CODE_BITS)))


def draw_frame_code(img: np.ndarray, value: int) -> None:
    """Draw `value` (0 ≤ value < 2**CODE_BITS) as CODE_BITS black (0) or white (1) squares along
    the bottom-left edge of `img (H, W, 3)`, in place, most significant bit first."""
    if not 0 <= value < 2**CODE_BITS:
        raise ValueError(f"frame code {value} outside 0..{2**CODE_BITS - 1}")
    s = _code_square(*img.shape[:2])
    y = img.shape[0] - s
    for i in range(CODE_BITS):
        bit = (value >> (CODE_BITS - 1 - i)) & 1
        img[y:, i * s : (i + 1) * s] = 255 * bit


def read_frame_code(img: np.ndarray) -> int:
    """The value `draw_frame_code` drew on `img (H, W, 3)` (read at each square's centre, so a
    lossy video keeps it)."""
    s = _code_square(*img.shape[:2])
    y = img.shape[0] - s // 2 - 1
    grey = np.asarray(img, np.float64).mean(axis=-1)
    value = 0
    for i in range(CODE_BITS):
        centre = grey[y - 1 : y + 2, i * s + s // 2 - 1 : i * s + s // 2 + 2].mean()
        value = (value << 1) | int(centre > 127)
    return value


# --------------------------------------------------------------------------------------------------
# The two halves


def robot_track(
    dataset: PathLike, clip: Clip, *, playback: PlaybackConfig, profile: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(command times (M,) s, angles (M, 11), clip frame index (M,)) of the clip's timeline as
    replay plays it on the sim backend, without the start and return moves."""
    from gesturebank.datasets.listing import clip_timeline
    from gesturebank.robot.backends.sim import SimBackend
    from gesturebank.robot.playback import play

    timeline = clip_timeline(
        dataset, clip.clip_id
    )  # unseen limbs held, as replay --clip plays them
    collector = SimBackend(Path("unused.mp4"))  # collects the commands; never closed
    play(timeline, collector, config=playback, profile=pepper.load_profile(profile))
    shown = [c for c in collector.commands if c.phase == "timeline"]
    times = np.array([c.t for c in shown])
    index = np.searchsorted(clip.times, times + 1e-6, side="right") - 1
    return times, np.stack([c.angles for c in shown]), np.clip(index, 0, len(clip.times) - 1)


def _source_frames(
    video: Path, *, start_s: float, end_s: float
) -> Iterator[tuple[float, np.ndarray]]:
    from gesturebank.extract.video import iter_frames

    # every frame (max_fps none): the source as it plays, not the detector's subset of it
    span = VideoConfig(start_s=max(0.0, start_s - 1.0), end_s=end_s + 1.0, max_fps=None)
    return iter_frames(video, span)


def _fit(img: np.ndarray, box: tuple[int, int, int, int], size: tuple[int, int]):
    """The crop `box` of `img` scaled into `size` (w, h), letterboxed; returns (panel, scale,
    offset) with panel = offset + scale · (image − box corner)."""
    x0, y0, x1, y1 = box
    w, h = size
    scale = min(w / max(x1 - x0, 1), h / max(y1 - y0, 1))
    sw, sh = max(1, round((x1 - x0) * scale)), max(1, round((y1 - y0) * scale))
    panel = np.empty((h, w, 3), np.uint8)
    panel[:] = _BACKGROUND
    ox, oy = (w - sw) // 2, (h - sh) // 2
    panel[oy : oy + sh, ox : ox + sw] = cv2.resize(
        img[y0:y1, x0:x1], (sw, sh), interpolation=cv2.INTER_AREA
    )
    return panel, scale, np.array([ox - x0 * scale, oy - y0 * scale])


def _draw_keypoints(panel: np.ndarray, xy: np.ndarray, valid: np.ndarray, scale: float) -> None:
    """COCO-17 keypoints `xy (17, 2)` (panel px) where `valid (17,)`, with their bones."""
    from gesturebank.skeletons import COCO17, COCO17_BONES

    thick = max(1, round(2 * scale * panel.shape[0] / 480))
    for a, b in COCO17_BONES:
        i, j = COCO17.index[a], COCO17.index[b]
        if valid[i] and valid[j]:
            p, q = np.round(xy[[i, j]]).astype(int)
            cv2.line(panel, tuple(p), tuple(q), BONE, max(2, thick), cv2.LINE_AA)
    for k in np.flatnonzero(valid):
        cv2.circle(panel, tuple(np.round(xy[k]).astype(int)), max(3, thick + 1), _JOINT, -1)


# --------------------------------------------------------------------------------------------------
# The video


def preview_clip(
    dataset: PathLike,
    *,
    clip_id: str,
    out: PathLike,
    render: RenderConfig,
    playback: PlaybackConfig,
    profile: str,
) -> Path:
    """Write the side-by-side preview of one clip to `out` (MP4, H.264 + AAC); returns it.

    The video has round(duration · render.frame_rate) frames, each half render.width_px ×
    render.height_px. Written under a hidden temporary name and renamed when complete.
    """
    from gesturebank.audio.io import read_audio
    from gesturebank.extract.video import frame_timestamps
    from gesturebank.robot.render import AUDIO_RATE, Scene, camera, mux_audio, poses_at
    from gesturebank.skeletons import to_coco17

    src = clip_source(dataset, clip_id)
    clip, fps = src.clip, render.frame_rate
    if src.status != "accepted":  # shown all the same: seeing why is what a preview is for
        log.warning("clip %s was %s by the QC: %s", clip_id, src.status, "; ".join(src.reasons))
    n_frames = max(1, round(clip.duration_s * fps))
    clock = np.arange(n_frames) / fps  # clip time of every output frame

    cmd_t, cmd_angles, cmd_index = robot_track(dataset, clip, playback=playback, profile=profile)
    poses = poses_at(cmd_t, cmd_angles, frame_times=clock)
    robot_frame = cmd_index[np.clip(np.searchsorted(cmd_t, clock + 1e-9, "right") - 1, 0, None)]

    kp = to_coco17(clip.pose2d.keypoints, clip.pose2d.skeleton)[..., :2]
    seen = kp[clip.valid]
    box = crop_box(
        seen, image_size=clip.pose2d.image_size, aspect=render.width_px / render.height_px
    )
    pose_t = clip.pose2d.timestamps
    pose_tol = float(np.median(np.diff(pose_t))) if len(pose_t) > 1 else np.inf
    source_t = frame_timestamps(src.video)  # every frame's time: the left half's frame index

    track = read_audio(src.video, sample_rate=AUDIO_RATE)
    if track is None:
        raise InputError(f"{src.video}: no audio track to mux into the preview of {clip_id}")
    first = round((clip.start_s - track.start_s) * AUDIO_RATE)  # the clip's start on the audio
    n_audio = round(n_frames / fps * AUDIO_RATE)
    sound = np.zeros(n_audio, np.float32)
    part = track.signal[max(first, 0) : max(first, 0) + n_audio - max(-first, 0)]
    sound[max(-first, 0) : max(-first, 0) + len(part)] = part

    scene = Scene(camera(render))
    w, h = render.width_px, render.height_px
    path = Path(out)
    frames = _source_frames(src.video, start_s=clip.start_s, end_s=clip.start_s + n_frames / fps)
    shown_t, shown = next(frames, (np.nan, None))
    if shown is None:
        raise InputError(f"{src.video}: no video frames in clip {clip_id}'s span")
    upcoming = next(frames, None)
    try:
        with atomic_open(path) as f, av.open(f, mode="w", format="mp4") as container:
            vstream = container.add_stream("libx264", rate=fps)
            vstream.width, vstream.height, vstream.pix_fmt = 2 * w, h, "yuv420p"
            vstream.options = {"crf": "20", "preset": "veryfast"}
            astream = container.add_stream("aac", rate=AUDIO_RATE, layout="mono")
            for k, t in enumerate(clock):
                while upcoming is not None and upcoming[0] <= clip.start_s + t + 1e-6:
                    shown_t, shown = upcoming
                    upcoming = next(frames, None)
                person, scale, offset = _fit(shown, box, (w, h))
                near = int(np.argmin(np.abs(pose_t - (shown_t - clip.start_s))))
                if abs(pose_t[near] - (shown_t - clip.start_s)) <= pose_tol:
                    _draw_keypoints(person, kp[near] * scale + offset, clip.valid[near], scale)
                robot = scene.render(poses[k])
                index = int(np.argmin(np.abs(source_t - shown_t)))
                _annotate(person, f"person  {t:5.2f} s", index, "video")
                _annotate(
                    robot,
                    "robot" + ("  (rejected clip)" if src.status != "accepted" else ""),
                    int(robot_frame[k]),
                    "clip",
                )
                img = np.ascontiguousarray(np.concatenate([person, robot], axis=1))
                for packet in vstream.encode(av.VideoFrame.from_ndarray(img, format="rgb24")):
                    container.mux(packet)
            container.mux(vstream.encode(None))
            mux_audio(container, astream, x=sound)
    except (av.FFmpegError, OSError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        raise InputError(f"{path}: cannot write video ({reason})") from None
    return path


def _annotate(panel: np.ndarray, label: str, code: int, what: str) -> None:
    """The half's label at the top; its frame code at the bottom with its legend beside it
    (`what frame N`), so the strip of squares reads as a frame number, not a glitch."""
    scale = panel.shape[0] / 480
    _text(panel, label, (12, round(30 * scale)), 0.7 * scale)
    draw_frame_code(panel, code)
    square = _code_square(*panel.shape[:2])
    legend_at = (CODE_BITS * square + round(8 * scale), panel.shape[0] - round(4 * scale))
    _text(panel, f"< {what} frame {code}", legend_at, 0.45 * scale)


def _text(panel: np.ndarray, text: str, at: tuple[int, int], size: float) -> None:
    """Dark text on a white outline: readable on any background."""
    cv2.putText(panel, text, at, cv2.FONT_HERSHEY_SIMPLEX, size, (255, 255, 255), 3, cv2.LINE_AA)
    cv2.putText(panel, text, at, cv2.FONT_HERSHEY_SIMPLEX, size, _TEXT, 1, cv2.LINE_AA)


def preview_take(
    dataset: PathLike,
    *,
    take_id: str,
    out_dir: PathLike,
    render: RenderConfig,
    playback: PlaybackConfig,
    profile: str,
) -> list[Path]:
    """One preview per clip of the take, `out_dir/<clip_id>.mp4`, in time order."""
    return [
        preview_clip(
            dataset,
            clip_id=clip_id,
            out=Path(out_dir) / f"{clip_id}.mp4",
            render=render,
            playback=playback,
            profile=profile,
        )
        for clip_id in take_clips(dataset, take_id)
    ]
