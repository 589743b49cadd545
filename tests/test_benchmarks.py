"""Every benchmark runs in its `--quick` mode, so none rots (benchmarks/README.md).

The scripts are found, not listed: each `benchmarks/*.py` whose source has a `"--quick"` flag is
run in a subprocess as a user would run it, from the repository, on the test's sample media;
the runs start with the session, beside the other tests (tests/quick_benchmarks.py).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.quick_benchmarks import QuickRuns

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
def test_quick_mode_runs_and_prints_a_table(
    script: Path, samples: Path, quick_runs: QuickRuns | None
) -> None:
    # run on `samples` in a subprocess as a user would, started with the session (conftest.py)
    assert quick_runs is not None and quick_runs.samples == samples
    done = quick_runs.result(script)
    # both streams: faults.py says which row failed on stderr and why (its table) on stdout
    assert done.returncode == 0, (
        f"{script.name} --quick exited {done.returncode}:\n{done.stderr}\n{done.stdout[-6000:]}"
    )
    assert any(c in done.stdout for c in BOX_CHARS), f"no table printed:\n{done.stdout}"
