"""`gesturebank render`: bad input is one line naming the file; a small render works."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gesturebank.synth.truth import Truth
from tests.synth.conftest import START_S

BIN = Path(sys.executable).parent / "gesturebank"


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(BIN), "render", *args], capture_output=True, text=True, timeout=120, check=False
    )


@pytest.mark.parametrize(
    ("content", "problem"),
    [(None, "BVH file not found"), ("HIERARCHY\nROOT Hips {\n", "not a BVH file")],
)
def test_a_missing_or_bad_bvh_is_one_line_naming_it(
    tmp_path: Path, content: str | None, problem: str
) -> None:
    bvh = tmp_path / "motion.bvh"
    if content is not None:
        bvh.write_text(content)
    r = run(str(bvh), str(tmp_path / "out"))
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and str(bvh) in lines[0], r.stderr


@pytest.mark.media
def test_bad_speech_is_one_line_naming_it(test_bvh: Path, tmp_path: Path) -> None:
    wav = tmp_path / "speech.wav"
    wav.write_text("not a wav")
    r = run(str(test_bvh), str(tmp_path / "out"), "--speech", str(wav), "--seconds", "0.1")
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and str(wav) in lines[0] and "WAV" in lines[0], r.stderr


def test_a_bad_size_is_one_line(tmp_path: Path) -> None:
    r = run(str(tmp_path / "x.bvh"), str(tmp_path / "out"), "--size", "big")
    assert r.returncode == 2 and r.stderr.strip() == (
        "error: --size 'big': expected WIDTHxHEIGHT, e.g. 1280x720"
    )


@pytest.mark.media
def test_a_two_camera_render(test_bvh: Path, tmp_path: Path) -> None:
    out = tmp_path / "take"
    args = ("--start", str(START_S), "--seconds", "0.2", "--size", "160x120", "--cameras", "2")
    r = run(str(test_bvh), str(out), *args)
    assert r.returncode == 0, r.stderr
    truth = Truth.load(out)
    assert truth.cameras.names == ["cam01", "cam02"]
    assert truth.joints2d.shape == (2, 6, 17, 2) and np.isfinite(truth.joints2d).all()
    assert all(v.is_file() for v in truth.videos)


def test_help_shows_the_allowed_values() -> None:
    r = run("--help")
    assert r.returncode == 0
    assert "tshirt|sleeves" in r.stdout and "1280x720" in r.stdout
