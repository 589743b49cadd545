"""A .wav much shorter than its video: the build warns, names the reason on the take's clips,
and QC judges only the span that was kept (issue #16, item 3)."""

import logging
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from scipy.io import wavfile

from gesturebank.app.build import build_dataset
from gesturebank.config import Config
from gesturebank.datasets.cut import trimmed_share
from gesturebank.datasets.refresh import refresh
from gesturebank.datasets.store import read_record
from gesturebank.datasets.takes import discover_takes


def test_trimmed_share_weighs_frames_by_their_duration() -> None:
    t = np.arange(0, 7.1, 1 / 30)
    assert trimmed_share(t, (0.0, 1.5)) == pytest.approx(1 - 1.5 / 7.1, abs=0.01)
    assert trimmed_share(t, (-1.0, 100.0)) == 0.0  # audio longer than the video drops nothing
    vfr = np.concatenate([np.arange(0, 1, 0.01), np.arange(1, 5, 0.1)])  # 100 frames in 1 s
    # 100 of 140 frames have audio, but only 1 of the 4.9 s (a frame count would say 29 %)
    assert trimmed_share(vfr, (0.0, 0.995)) == pytest.approx(3.91 / 4.91)


def test_short_wav_warns_and_rejects_what_is_kept(
    samples: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    videos, out = tmp_path / "videos", tmp_path / "out"
    (videos / "s1").mkdir(parents=True)
    (videos / "s1" / "talk.mp4").symlink_to(samples / "talking/lab/cam01_arctic.mp4")  # 7.1 s
    rate, speech = wavfile.read(samples / "speech/arctic_a0007.wav")
    wav = videos / "s1" / "talk.wav"
    wavfile.write(wav, rate, speech[: int(1.5 * rate)])  # 1.5 s of studio audio
    settings = {"clips": {"min_s": 1.0}, "build": {"workers": 1}}
    config = Config.model_validate(settings)
    with caplog.at_level(logging.WARNING, logger="gesturebank.app.take"):
        summary = build_dataset(discover_takes(videos), videos_dir=videos, out=out, config=config)
    assert not summary.failed
    record = read_record(out, "s1__talk")
    assert record is not None
    clips = record.data_clips
    assert clips, "the 1.5 s with audio give a clip (clips.min_s = 1)"
    share = clips[0].metrics["trimmed_fraction"]
    assert share == pytest.approx(1 - 1.5 / 7.1, abs=0.02)
    warned = [r.getMessage() for r in caplog.records if "trimming" in r.getMessage()]
    assert len(warned) == 1 and str(wav) in warned[0] and f"drops {share:.0%}" in warned[0]
    for c in clips:
        assert c.qc_status == "rejected"
        assert f"trimming to their common span drops {share:.0%}" in " ".join(c.qc_reasons)
        assert c.end_s <= 1.5 + 0.05  # QC judged only what was kept
    assert any(s.qc_reasons == ("no audio",) and s.end_s > 7 for s in record.clips)
    # measured again with other settings, the take's share is kept; a looser threshold admits
    looser = {"analysis_rate_hz": 25.0, "max_trimmed_fraction": 0.9}
    refresh(out, Config.model_validate({**settings, "qc": looser}))
    rows = pq.read_table(out / "manifest.parquet").to_pylist()
    kept = [r for r in rows if r["kind"] == "clip"]
    assert kept and all(dict(r["metrics"])["trimmed_fraction"] == share for r in kept)
    assert not any("trimming" in reason for r in kept for reason in r["qc_reasons"])


def test_takes_with_their_own_audio_lose_nothing(demo_dataset: Path) -> None:
    rows = pq.read_table(demo_dataset / "manifest.parquet").to_pylist()
    clips = [r for r in rows if r["kind"] == "clip"]
    assert clips and all(dict(r["metrics"])["trimmed_fraction"] < 0.05 for r in clips)
