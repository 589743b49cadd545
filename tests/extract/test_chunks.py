"""Long videos in time chunks: the plan covers every frame once, stitching gives back the take
(people keep their identity across chunks), and on real footage a chunked detection has the
unchunked one's frames and people."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturebank.config import Config
from gesturebank.extract.cache import DetectionCache
from gesturebank.extract.chunks import Chunk, plan_chunks, stitch, video_chunks
from gesturebank.extract.shots import Shots
from gesturebank.poses import MultiPose2D


@pytest.mark.parametrize(
    ("n", "fps", "chunk_s", "overlap_s"), [(300, 10.0, 7.0, 2.0), (601, 30.0, 5.0, 0.0)]
)
def test_the_plan_owns_every_frame_once_and_warms_up_before_it(
    n: int, fps: float, chunk_s: float, overlap_s: float
) -> None:
    rng = np.random.default_rng(0)
    ts = np.cumsum(rng.uniform(0.5, 1.5, n)) / fps  # irregular (VFR) frame times
    chunks = plan_chunks(timestamps=ts, chunk_s=chunk_s, overlap_s=overlap_s)
    assert len(chunks) == int(np.ceil((ts[-1] - ts[0]) / chunk_s))
    owner = np.zeros(n, int)
    for k, c in enumerate(chunks):
        assert c.own_s in ts and c.start_s in ts  # bounds are frame times
        hi = np.inf if c.end_s is None else c.end_s
        owner += (ts >= c.own_s) & (ts < hi)
        lengths = (hi if c.end_s is not None else ts[-1]) - c.own_s
        assert lengths <= chunk_s + 1e-9
        if k:
            assert c.own_s - c.start_s >= overlap_s - 2 / fps * 1.5  # the warm-up is there
            assert c.start_s >= c.own_s - overlap_s - 1e-9
            assert chunks[k - 1].end_s == c.own_s
    assert np.all(owner == 1)
    assert chunks[0].start_s == chunks[0].own_s == ts[0] and chunks[-1].end_s is None


def test_a_short_video_is_one_chunk() -> None:
    ts = np.arange(100) / 10.0
    assert plan_chunks(timestamps=ts, chunk_s=9.9, overlap_s=1.0) == []
    assert len(plan_chunks(timestamps=ts, chunk_s=9.8, overlap_s=1.0)) == 2


def _people(n: int) -> MultiPose2D:
    """Three people walking past each other (x crossing), one leaving for a while."""
    t = np.arange(n) / 10.0
    k = 33
    kp = np.full((n, 3, k, 3), np.nan, np.float32)
    for p, (x0, vx) in enumerate([(100, 20), (900, -20), (500, 3)]):
        x = x0 + vx * t[:, None] + np.linspace(-30, 30, k)[None]
        y = np.broadcast_to(np.linspace(100, 500, k) + 20 * p, (n, k))
        kp[:, p, :, 0], kp[:, p, :, 1], kp[:, p, :, 2] = x, y, 0.9
    gone = (t > 12) & (t < 18)
    kp[gone, 2] = np.nan
    ids = np.where(np.isfinite(kp[..., 0, 0]), np.arange(3)[None], -1)
    return MultiPose2D(kp, t, "blazepose33", (1000, 600), None, ids)


def test_stitching_chunks_gives_back_the_take_with_its_identities() -> None:
    whole = _people(400)
    cuts = whole.timestamps[[55, 250]]
    change = np.linspace(0, 50, 400).astype(np.float32)
    chunks = plan_chunks(timestamps=whole.timestamps, chunk_s=11.0, overlap_s=3.0)
    assert len(chunks) == 4
    rng = np.random.default_rng(1)
    parts = []
    for c in chunks:
        hi = np.inf if c.end_s is None else c.end_s
        frames = np.flatnonzero((whole.timestamps >= c.start_s) & (whole.timestamps < hi))
        part = whole.take(frames)
        # each chunk's detector numbers its people its own way, in other slots
        slots = rng.permutation(3)
        ids = np.where(part.ids >= 0, part.ids + 10 * (len(parts) + 1), -1)[:, slots]
        part = MultiPose2D(
            part.keypoints[:, slots], part.timestamps, part.skeleton, part.image_size, None, ids
        )
        ts = part.timestamps
        shots = Shots(ts, cuts[(cuts > ts[0]) & (cuts < ts[-1])], change[frames])
        parts.append((c, part, shots))
    multi, shots = stitch(parts=parts)
    np.testing.assert_array_equal(multi.timestamps, whole.timestamps)
    np.testing.assert_array_equal(shots.cuts, cuts)
    np.testing.assert_array_equal(shots.change, change)
    assert multi.ids is not None
    # every person keeps one id through the take, and the three stay apart
    for p in range(3):
        seen = np.flatnonzero(np.isfinite(whole.keypoints[:, p, 0, 0]))
        same = (multi.keypoints[seen] == whole.keypoints[seen, p][:, None]).all(axis=(2, 3))
        assert np.all(same.sum(axis=1) == 1)  # each frame holds the person once
        got = multi.ids[seen, np.argmax(same, axis=1)]
        assert len(np.unique(got)) == 1, (p, np.unique(got))
    assert len(np.unique(multi.ids[multi.ids >= 0])) == 3


def test_a_person_only_in_a_later_chunk_gets_a_new_identity() -> None:
    whole = _people(200)
    first = whole.take(np.arange(0, 120))
    second = whole.take(np.arange(90, 200))
    # in the second chunk, somebody else stands where person 2 stood
    kp = second.keypoints.copy()
    kp[:, 2, :, 0] += 300
    second = MultiPose2D(
        kp, second.timestamps, second.skeleton, second.image_size, None, second.ids
    )
    parts = [
        (Chunk(0.0, 0.0, 10.0), first, Shots(first.timestamps, np.zeros(0), np.zeros(120))),
        (Chunk(9.0, 10.0, None), second, Shots(second.timestamps, np.zeros(0), np.zeros(110))),
    ]
    multi, _ = stitch(parts=parts)
    assert multi.ids is not None
    before, after = multi.ids[:100], multi.ids[100:]
    assert set(np.unique(after[after >= 0])) - set(np.unique(before[before >= 0])) == {3}


@pytest.mark.slow
def test_a_chunked_detection_has_the_frames_and_people_of_one_pass(
    samples: Path, tmp_path: Path
) -> None:
    """Sports2D's demo (a man walking across the whole picture, a far person at the top, a
    third later) in 3 chunks with a 1 s warm-up: the same timestamps and cuts as one pass,
    and the walker as one track in the same frames, within a pixel.

    Not asserted, because chunks cannot give it: the far person is tracked from the first frame
    in one pass, but the person detector alone does not find him at the third chunk's start."""
    from gesturebank.app.extract import detect_people, detecting, extract_take

    video = samples / "sports2d" / "Demo" / "demo.mp4"
    config = Config.model_validate({"build": {"chunk_s": 2.6, "chunk_overlap_s": 1.0}})
    found = detect_people(video, config, cache=DetectionCache(tmp_path / "one"))
    one, shots_one = found.multi, found.shots
    plan = video_chunks(
        str(video), video=config.video, build=config.build, detector=config.detector.name
    )
    assert len(plan) == 3
    chunks = DetectionCache(tmp_path / "chunks")
    for _, video_config in plan[1:]:  # what the build's chunk tasks do; the first is left out
        detect_people(video, detecting(config, video_config), cache=chunks)
    assert len(list(chunks.root.glob("*.npz"))) == 2
    ext = extract_take(video, config, chunks=chunks, with_audio=False)
    assert len(list(chunks.root.glob("*.npz"))) == 3  # it detected the missing one itself
    multi = ext.multi
    np.testing.assert_array_equal(multi.timestamps, one.timestamps)
    np.testing.assert_array_equal(ext.shots.cuts, shots_one.cuts)

    def hips(m: MultiPose2D, track: int) -> np.ndarray:
        """(T, 2) mid-hip of `track`, NaN where it is not."""
        assert m.ids is not None
        x = np.full((len(m), 2), np.nan)
        t, s = np.nonzero(m.ids == track)
        x[t] = m.keypoints[t, s][:, [23, 24], :2].mean(axis=1)
        return x

    assert one.ids is not None and multi.ids is not None
    travel = {
        k: np.ptp(hips(one, k)[:, 0][np.isfinite(hips(one, k)[:, 0])])
        for k in set(one.ids[one.ids >= 0].tolist())
    }
    x = hips(one, max(travel, key=travel.__getitem__))  # the walker goes farthest
    seen = np.isfinite(x[:, 0])
    assert seen[: int(np.searchsorted(one.timestamps, plan[1][0].own_s))].any()
    assert seen[int(np.searchsorted(one.timestamps, plan[2][0].own_s)) :].any()  # all 3 chunks
    tracks = [int(k) for k in np.unique(multi.ids[multi.ids >= 0])]
    found = [hips(multi, k) for k in tracks]
    nearest = min(found, key=lambda y: float(np.nanmedian(np.linalg.norm(x - y, axis=1))))
    np.testing.assert_array_equal(np.isfinite(nearest[:, 0]), seen)
    assert np.median(np.linalg.norm(x[seen] - nearest[seen], axis=1)) < 1.0  # px
