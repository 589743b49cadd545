"""fetch-samples: real media from the registry, pinned checksums, idempotent, self-repairing."""

import dataclasses
import shutil
from pathlib import Path

import av
import pytest

from gesturebank import samples as S
from gesturebank.errors import FetchError

SPORTS2D = next(a for a in S.ARCHIVES if a.project == "sports2d")


def mtimes(root: Path) -> dict[str, int]:
    return {str(p.relative_to(root)): p.stat().st_mtime_ns for p in root.rglob("*") if p.is_file()}


@pytest.fixture(scope="module")
def first_fetch(
    samples: Path, tmp_path_factory: pytest.TempPathFactory
) -> tuple[Path, S.FetchReport]:
    """A new samples folder filled from the (warm) download cache, once (~25 s: the talking
    clips are encoded)."""
    root = tmp_path_factory.mktemp("first-fetch") / "samples"
    return root, S.fetch_samples(root)


@pytest.fixture
def fresh(first_fetch: tuple[Path, S.FetchReport], tmp_path: Path) -> tuple[Path, S.FetchReport]:
    """A copy of that folder (mtimes kept) and its first fetch's report, for a test to change."""
    template, report = first_fetch
    return Path(shutil.copytree(template, tmp_path / "samples")), report


def test_first_fetch_writes_everything_and_the_second_nothing(fresh) -> None:
    root, first = fresh
    assert "pose2sim/Demo_SinglePerson/videos/cam01.mp4" in first.written
    assert "speech/arctic_a0007.wav" in first.written
    assert "pose2sim/LICENSE" in first.written
    assert not any(".gitkeep" in w for w in first.written)
    before = mtimes(root)
    second = S.fetch_samples(root)
    assert (second.downloaded, second.written) == ([], [])
    assert second.verified == len(first.written)
    assert mtimes(root) == before


def test_corrupted_and_missing_files_are_detected_and_repaired(fresh) -> None:
    root, _ = fresh
    wav = root / "speech/arctic_a0007.wav"
    good = S.sha256_file(wav)
    data = bytearray(wav.read_bytes())
    data[5000] ^= 0xFF  # one flipped byte
    wav.write_bytes(bytes(data))
    (root / "sports2d/LICENSE").unlink()
    (root / "talking/outdoor/sports2d_arctic.mp4").write_bytes(b"truncated")
    report = S.fetch_samples(root)
    assert set(report.written) == {
        "speech/arctic_a0007.wav",
        "sports2d/LICENSE",
        "talking/outdoor/sports2d_arctic.mp4",
    }
    assert S.sha256_file(wav) == good
    assert report.downloaded == []


def test_corrupted_cached_archive_is_downloaded_again(samples, tmp_path, monkeypatch) -> None:
    cache = tmp_path / "cache"
    cache.mkdir()
    shutil.copy(S.default_download_dir() / SPORTS2D.filename, cache)
    with open(cache / SPORTS2D.filename, "r+b") as f:
        f.seek(1000)
        f.write(b"\0" * 64)
    monkeypatch.setattr(S, "ARCHIVES", (SPORTS2D,))
    monkeypatch.setattr(S, "TALKING", ())
    report = S.fetch_samples(tmp_path / "s", cache)
    assert report.downloaded == [SPORTS2D.filename]
    assert S.sha256_file(cache / SPORTS2D.filename) == SPORTS2D.sha256
    assert (tmp_path / "s/sports2d/Demo/demo.mp4").is_file()


def test_download_not_matching_the_pin_fails_naming_the_file(tmp_path, monkeypatch) -> None:
    wrong = dataclasses.replace(SPORTS2D, sha256="0" * 64)
    monkeypatch.setattr(S, "ARCHIVES", (wrong,))
    monkeypatch.setattr(S, "TALKING", ())
    with pytest.raises(FetchError, match=rf"{SPORTS2D.filename}: sha256 \w+ does not match"):
        S.fetch_samples(tmp_path / "s", tmp_path / "cache")
    assert not (tmp_path / "cache" / SPORTS2D.filename).exists()  # a bad download is not kept


@pytest.mark.parametrize(
    ("clip", "frames", "seconds"),
    [
        ("talking/lab/cam01_arctic.mp4", 426, 7.1),
        ("talking/outdoor/sports2d_arctic.mp4", 230, 7.67),
    ],
)
def test_talking_clips_have_the_real_video_and_speech(samples, clip, frames, seconds) -> None:
    with av.open(str(samples / clip)) as c:
        video, audio = c.streams.video[0], c.streams.audio[0]
        assert audio.codec_context.sample_rate == 16000
        n_video = sum(1 for _ in c.decode(video))
    with av.open(str(samples / clip)) as c:
        n_audio = sum(f.samples for f in c.decode(audio=0))
    assert n_video == frames
    assert n_audio / 16000 == pytest.approx(seconds, abs=0.15)


def test_a_demo_no_longer_made_is_removed_and_the_manifest_kept(fresh, monkeypatch) -> None:
    """An older version's demo would be built as a take: it goes, and the manifest says so."""
    root, _ = fresh
    monkeypatch.setattr(S, "TALKING", tuple(t for t in S.TALKING if "outdoor" in t[0]))
    S.fetch_samples(root)
    assert not (root / "talking/lab/cam01_arctic.mp4").exists()
    assert "talking/lab/cam01_arctic.mp4" not in (root / S.MANIFEST).read_text()
    again = S.fetch_samples(root)
    assert (again.downloaded, again.written) == ([], [])
