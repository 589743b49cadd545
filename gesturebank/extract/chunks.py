"""Long videos detected in time chunks, and the chunks' people stitched back into one take.

A video longer than `build.chunk_s` is split at frame times into chunks of equal length, so
that each chunk's detection is a task of its own. Chunk k is detected from `start_s`, up to
`build.chunk_overlap_s` before the first frame it owns (`own_s`): the detector tracks causally,
so these warm-up frames let its tracking settle before the frames that count, and they are the
frames where chunk k's people are matched to chunk k−1's. Chunk k owns its frames up to the next
chunk's `own_s`.

Every chunk starts on a frame the whole video's selection keeps (`video.select_indices`), so
the stride and `max_fps` keep the same frames in a chunk as in one pass over the video: the
stitched take has the unchunked take's timestamps exactly.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from gesturebank.config import BuildConfig, VideoConfig
from gesturebank.extract.shots import Shots
from gesturebank.poses import MultiPose2D

# Largest median keypoint distance, in person heights, at which two chunks' tracks over the
# same warm-up frames are the same person (the same detector on the same frames: one person's
# tracks differ by landmark noise, a few hundredths; two people by their distance apart).
SAME_PERSON = 0.25


@dataclass(frozen=True)
class Chunk:
    """One chunk's frames: detected from `start_s`, owned from `own_s` (seconds, frame times)
    up to `end_s` (exclusive; None: the end of the selected range)."""

    start_s: float
    own_s: float
    end_s: float | None


def plan_chunks(*, timestamps: np.ndarray, chunk_s: float, overlap_s: float) -> list[Chunk]:
    """The chunks of a video whose selected frames are at `timestamps` (sorted seconds): as few
    equal chunks of at most `chunk_s` as cover them; [] when one chunk would do."""
    ts = np.asarray(timestamps, dtype=np.float64)
    if len(ts) < 2 or ts[-1] - ts[0] <= chunk_s:
        return []
    n = int(np.ceil((ts[-1] - ts[0]) / chunk_s))
    own = np.unique(np.searchsorted(ts, ts[0] + (ts[-1] - ts[0]) * np.arange(n) / n))
    starts = np.searchsorted(ts, ts[own] - overlap_s)
    ends = [float(ts[i]) for i in own[1:]] + [None]
    return [Chunk(float(ts[s]), float(ts[o]), e) for s, o, e in zip(starts, own, ends, strict=True)]


def chunk_video_config(chunk: Chunk, video: VideoConfig, *, half_frame_s: float) -> VideoConfig:
    """`video` restricted to `chunk`'s detected frames. The bounds sit half a frame before the
    frame times, so that float rounding cannot move a frame in or out."""
    start = max(0.0, chunk.start_s - half_frame_s)
    end = video.end_s if chunk.end_s is None else chunk.end_s - half_frame_s
    return video.model_copy(update={"start_s": start, "end_s": end})


def video_chunks(
    path: str, *, video: VideoConfig, build: BuildConfig, detector: str
) -> list[tuple[Chunk, VideoConfig]]:
    """The chunks `path` is detected in under `build.chunk_s` by the detector named `detector`,
    each with the video settings that detect it (`app.extract.detecting`); [] when it is
    detected in one pass (short, chunking off, or a detector that reads precomputed keypoints
    instead of frames). Reads only the container's packets."""
    from gesturebank.extract.detectors import DETECTORS
    from gesturebank.extract.video import frame_timestamps, probe, select_indices

    chunk_s = build.chunk_s
    if chunk_s is None or not getattr(DETECTORS.get(detector), "needs_pixels", True):
        return []
    info = probe(path)
    end = video.end_s if video.end_s is not None else info.duration_s
    if np.isfinite(end) and end - video.start_s <= chunk_s:
        return []  # short: the headers say so, no need to read the packets
    every = frame_timestamps(path)
    selected = every[select_indices(every, video)]
    chunks = plan_chunks(timestamps=selected, chunk_s=chunk_s, overlap_s=build.chunk_overlap_s)
    half = float(np.min(np.diff(every))) / 2 if len(every) > 1 else 0.0
    return [(c, chunk_video_config(c, video, half_frame_s=half)) for c in chunks]


def _heights(points: np.ndarray) -> np.ndarray:
    """`(..., K, 3)` keypoints → `(...)` vertical extent of each person, px (NaN: nobody)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: nobody there
        return np.nanmax(points[..., 1], axis=-1) - np.nanmin(points[..., 1], axis=-1)


def match_tracks(
    *, before: MultiPose2D, after: MultiPose2D, same_person: float = SAME_PERSON
) -> dict[int, int]:
    """{track id in `after`: track id in `before`} for the people both saw on the same frames
    (equal timestamps), matched one to one by their median keypoint distance in person
    heights (at most `same_person`)."""
    assert before.ids is not None and after.ids is not None
    common, ib, ia = np.intersect1d(before.timestamps, after.timestamps, return_indices=True)
    if len(common) == 0:
        return {}
    ids_b, ids_a = before.ids[ib], after.ids[ia]
    kp_b, kp_a = before.keypoints[ib], after.keypoints[ia]
    tracks_b = [int(k) for k in np.unique(ids_b) if k >= 0]
    tracks_a = [int(k) for k in np.unique(ids_a) if k >= 0]
    cost = np.full((len(tracks_a), len(tracks_b)), np.inf)
    for i, a in enumerate(tracks_a):
        for j, b in enumerate(tracks_b):
            sa, sb = ids_a == a, ids_b == b  # (N, P) the slot holding each track
            both = sa.any(axis=1) & sb.any(axis=1)
            if not both.any():
                continue
            pa = kp_a[both][sa[both]]  # (M, K, 3): one slot per frame
            pb = kp_b[both][sb[both]]
            dist = np.linalg.norm(pa[..., :2] - pb[..., :2], axis=-1)  # (M, K)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # frames with no common point
                per_frame = np.nanmedian(dist, axis=-1) / _heights(pb)
            if np.isfinite(per_frame).any():
                cost[i, j] = float(np.nanmedian(per_frame))
    if not np.isfinite(cost).any():
        return {}
    rows, cols = linear_sum_assignment(np.where(np.isfinite(cost), cost, 1e9))
    pairs = zip(rows, cols, strict=True)
    return {tracks_a[r]: tracks_b[c] for r, c in pairs if cost[r, c] <= same_person}


def stitch(*, parts: list[tuple[Chunk, MultiPose2D, Shots]]) -> tuple[MultiPose2D, Shots]:
    """One take from its chunks' detections and shots (in time order): each chunk's own frames,
    its people carrying the track ids of the same people in the chunk before (matched on the
    frames both detected), its cuts in its own frames."""
    kept: list[MultiPose2D] = []
    cuts: list[np.ndarray] = []
    change: list[np.ndarray] = []
    previous: MultiPose2D | None = None
    next_id = 0
    for k, (chunk, multi, shot) in enumerate(parts):
        if multi.ids is not None:
            multi = _relabelled(multi, previous, next_id)
            next_id = max(next_id, int(multi.ids.max(initial=-1)) + 1)  # type: ignore[union-attr]
        previous = multi
        lo = -np.inf if k == 0 else chunk.own_s
        hi = parts[k + 1][0].own_s if k + 1 < len(parts) else np.inf
        own = np.flatnonzero((multi.timestamps >= lo) & (multi.timestamps < hi))
        kept.append(multi.take(own))
        cuts.append(shot.cuts[np.isin(shot.cuts, multi.timestamps[own])])
        change.append(shot.change[own])
    stitched = _concatenate(kept)
    return stitched, Shots(stitched.timestamps, np.concatenate(cuts), np.concatenate(change))


def _relabelled(multi: MultiPose2D, previous: MultiPose2D | None, next_id: int) -> MultiPose2D:
    """`multi` with its track ids mapped to `previous`'s for the same people, fresh ids (from
    `next_id`) for the others."""
    assert multi.ids is not None
    matched = {} if previous is None else match_tracks(before=previous, after=multi)
    mapping = {}
    for track in (int(k) for k in np.unique(multi.ids) if k >= 0):
        if track in matched:
            mapping[track] = matched[track]
        else:
            mapping[track] = next_id
            next_id += 1
    ids = np.array([mapping.get(int(k), -1) for k in multi.ids.ravel()], np.int64)
    return MultiPose2D(
        multi.keypoints,
        multi.timestamps,
        multi.skeleton,
        multi.image_size,
        multi.world,
        ids.reshape(multi.ids.shape),
    )


def _concatenate(parts: list[MultiPose2D]) -> MultiPose2D:
    """Frames of `parts` one after another, in as many slots as the widest has."""
    slots = max(p.keypoints.shape[1] for p in parts)

    def padded(a: np.ndarray | None, fill: float) -> np.ndarray | None:
        if a is None:
            return None
        pad = [(0, 0), (0, slots - a.shape[1])] + [(0, 0)] * (a.ndim - 2)
        return np.pad(a, pad, constant_values=fill)

    worlds = [padded(p.world, np.nan) for p in parts]
    ids = [padded(p.ids, -1) for p in parts]
    first = parts[0]
    return MultiPose2D(
        np.concatenate([padded(p.keypoints, np.nan) for p in parts]),
        np.concatenate([p.timestamps for p in parts]),
        first.skeleton,
        first.image_size,
        None if any(w is None for w in worlds) else np.concatenate(worlds),  # type: ignore[arg-type]
        None if any(i is None for i in ids) else np.concatenate(ids),  # type: ignore[arg-type]
    )
