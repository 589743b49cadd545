"""Speech activity on real takes (issue 32, item 2): a take whose audio is digital silence keeps
nothing, with the reason "no speech"; a silence over speech.max_silence_s in the middle of a take
cuts it there, a shorter one is marked in the clip's `speech`.

The takes are the talking demo's videos with their audio replaced by a .wav beside them (made
here from the video's own track; the detections come from the cache, so each build is short).
"""

from pathlib import Path

import numpy as np
from scipy.io import wavfile

from gesturebank.app.build import build_dataset
from gesturebank.audio.io import read_audio
from gesturebank.config import Config
from gesturebank.datasets import open as open_dataset
from gesturebank.datasets.cut import SILENCE
from gesturebank.datasets.takes import discover_takes

RATE = 16000


def _take_with_audio(samples: Path, root: Path, video: str, edit) -> Path:
    """A videos folder with one take: `video` (from samples/talking) and, beside it, its own
    audio track changed by `edit(signal) -> signal` as a 16-bit .wav."""
    videos = root / "videos"
    (videos / "s1").mkdir(parents=True)
    source = samples / "talking" / video
    (videos / "s1" / "talk.mp4").symlink_to(source)
    audio = read_audio(source, sample_rate=RATE)
    assert audio is not None and abs(audio.start_offset_s) < 0.05  # the .wav starts with it
    signal = edit(np.asarray(audio.signal, np.float64))
    wavfile.write(videos / "s1" / "talk.wav", RATE, (np.clip(signal, -1, 1) * 32767).astype("<i2"))
    return videos


def _build(videos: Path, out: Path, **sections) -> list:
    config = Config.model_validate({"build": {"workers": 1}, **sections})
    summary = build_dataset(discover_takes(videos), videos_dir=videos, out=out, config=config)
    assert not summary.failed, summary.failed
    return open_dataset(out).rows()


def test_a_silent_take_keeps_nothing_and_says_no_speech(samples: Path, tmp_path: Path) -> None:
    videos = _take_with_audio(samples, tmp_path, "outdoor/sports2d_arctic.mp4", np.zeros_like)
    rows = _build(videos, tmp_path / "out")
    assert not [r for r in rows if r.clip.qc_status == "accepted"]
    # the whole take is one silence longer than 2 s: cut, so it gives no clip at all
    assert not [r for r in rows if r.clip.kind == "clip"]
    silent = [r.clip for r in rows if r.clip.qc_reasons == (SILENCE,)]
    assert sum(c.end_s - c.start_s for c in silent) > 5.0  # of the take's 5.7 s
    # with silences never cut, the take gives a clip, and the QC rejects it: no speech in it
    rows = _build(videos, tmp_path / "uncut", speech={"max_silence_s": 60.0})
    clips = [r.clip for r in rows if r.clip.kind == "clip"]
    assert clips and all(c.qc_status == "rejected" for c in clips)
    for c in clips:
        assert c.metrics["speech_fraction"] == 0.0
        assert any(reason.startswith("no speech: speech heard in 0%") for reason in c.qc_reasons)


def test_a_long_silence_in_the_middle_cuts_a_short_one_is_marked(
    samples: Path, tmp_path: Path
) -> None:
    """The lab demo (7.1 s of speech) with 2.2 s (31 %) of digital silence from 2.5 s."""
    gap = (2.5, 4.7)

    def silence_in_the_middle(signal: np.ndarray) -> np.ndarray:
        out = signal.copy()
        out[int(gap[0] * RATE) : int(gap[1] * RATE)] = 0.0
        return out

    videos = _take_with_audio(samples, tmp_path, "lab/cam01_arctic.mp4", silence_in_the_middle)
    rows = _build(videos, tmp_path / "out", clips={"min_s": 1.0})
    clips = sorted((r.clip for r in rows if r.clip.kind == "clip"), key=lambda c: c.start_s)
    (cut,) = [r.clip for r in rows if r.clip.qc_reasons == (SILENCE,)]
    # the cut covers the inserted silence (the speech's own pauses may lengthen it)
    assert cut.start_s <= gap[0] + 0.1 and cut.end_s >= gap[1] - 0.1
    assert cut.end_s - cut.start_s < gap[1] - gap[0] + 1.0
    before = [c for c in clips if c.end_s <= cut.start_s + 0.05]
    after = [c for c in clips if c.start_s >= cut.end_s - 0.05]
    assert before and after and len(before) + len(after) == len(clips)  # clips either side
    assert all(c.qc_status == "accepted" for c in clips), [c.qc_reasons for c in clips]
    # silences up to 3 s only marked: one clip across the gap, `speech` false over it
    ds_rows = _build(videos, tmp_path / "marked", clips={"min_s": 1.0}, speech={"max_silence_s": 3})
    assert not [r for r in ds_rows if r.clip.qc_reasons == (SILENCE,)]
    ds = open_dataset(tmp_path / "marked")
    (whole,) = [ds.load(r.clip.clip_id) for r in ds_rows if r.clip.kind == "clip"]
    t = whole.times + whole.start_s  # on the video's clock
    inside = (t > gap[0] + 0.1) & (t < gap[1] - 0.1)
    assert inside.sum() > 150 and not whole.speech[inside].any()
    assert whole.speech[~inside].mean() > 0.8  # the rest is speech (ARCTIC has short pauses)
