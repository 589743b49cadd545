"""Every benchmark runs in its `--quick` mode, so none rots (benchmarks/README.md).

The scripts are found, not listed: each `benchmarks/*.py` whose source has a `"--quick"` flag is
run in a subprocess as a user would run it, from the repository, on the test's sample media.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted((ROOT / "benchmarks").glob("*.py"))

# Quick modes that take more than ~30 s on the 2-core development machine (build.py: ~42 s,
# faults.py: ~4 min).
SLOW: set[str] = {"build.py", "faults.py"}

# Lines of a rich table (its box) in any of rich's box styles.
BOX_CHARS = "─━│┃"


def _has_quick(script: Path) -> bool:
    return '"--quick"' in script.read_text(encoding="utf-8")


def _quick_params() -> list[object]:
    return [
        pytest.param(s, id=s.name, marks=[pytest.mark.slow] if s.name in SLOW else [])
        for s in SCRIPTS
        if _has_quick(s)
    ]


def test_every_benchmark_has_a_quick_mode() -> None:
    missing = [s.name for s in SCRIPTS if not _has_quick(s)]
    assert not missing, f"benchmarks without a --quick flag (make test runs them): {missing}"


@pytest.mark.parametrize("script", _quick_params())
def test_quick_mode_runs_and_prints_a_table(script: Path, samples: Path) -> None:
    # UTF-8 out, so rich draws its box characters rather than an ASCII fallback.
    env = os.environ | {"GESTUREBANK_SAMPLES": str(samples), "PYTHONIOENCODING": "utf-8"}
    done = subprocess.run(
        [sys.executable, str(script), "--quick"],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        encoding="utf-8",
        timeout=900,  # a guard against a hang, not a speed requirement
    )
    # both streams: faults.py says which row failed on stderr and why (its table) on stdout
    assert done.returncode == 0, (
        f"{script.name} --quick exited {done.returncode}:\n{done.stderr}\n{done.stdout[-6000:]}"
    )
    assert any(c in done.stdout for c in BOX_CHARS), f"no table printed:\n{done.stdout}"
