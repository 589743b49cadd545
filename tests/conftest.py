"""Shared fixtures: the real sample media, fetched (and checksummed) by the project's own code."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.quick_benchmarks import QuickRuns

QUICK_RUNS = pytest.StashKey[QuickRuns]()


@pytest.fixture(scope="session")
def samples() -> Path:
    """Folder of real sample media (see `gesturebank fetch-samples`), fetched on first use."""
    from gesturebank.samples import default_samples_dir, fetch_samples

    root = default_samples_dir()  # $GESTUREBANK_SAMPLES (the Makefile sets it) or the cache dir
    fetch_samples(root)
    return root


@pytest.fixture(scope="session", autouse=True)
def quick_runs(request: pytest.FixtureRequest) -> Iterator[QuickRuns | None]:
    """The selected benchmarks' --quick runs, started with the session beside the tests
    (tests/quick_benchmarks.py); None when no benchmark test is selected."""
    scripts = [
        item.callspec.params["script"]
        for item in request.session.items
        if isinstance(item, pytest.Function)
        and item.originalname == "test_quick_mode_runs_and_prints_a_table"
    ]
    try:
        samples = request.getfixturevalue("samples") if scripts else None
    except Exception:  # no media: the tests that need it fail on their own `samples`, not all
        samples = None
    if samples is None:
        yield None
        return
    runs = QuickRuns(scripts, samples)
    request.config.stash[QUICK_RUNS] = runs
    try:
        yield runs
    finally:
        runs.close()


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    runs = terminalreporter.config.stash.get(QUICK_RUNS, None)
    if runs is not None and runs.seconds:
        terminalreporter.write_line(f"benchmarks' --quick runs: {runs.report()}")


@pytest.fixture(scope="session")
def artifacts() -> Path:
    """Folder for files a person may want to look at after the run (screenshots, renders)."""
    path = Path(os.environ.get("GESTUREBANK_TEST_ARTIFACTS", "test-artifacts"))
    path.mkdir(parents=True, exist_ok=True)
    return path


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Tests that use the real sample media carry the `media` marker (`-m "not media"` skips)."""
    for item in items:
        if "samples" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.media)


@pytest.fixture(scope="session")
def demo_dataset(samples: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A dataset built once per session from the real talking demo clips (local pool), with its
    QC dashboard."""
    from gesturebank.app.build import build_dataset
    from gesturebank.config import Config
    from gesturebank.datasets.takes import discover_takes
    from gesturebank.report import write_dashboard

    videos = samples / "talking"
    out = tmp_path_factory.mktemp("demo-dataset")
    summary = build_dataset(discover_takes(videos), videos_dir=videos, out=out, config=Config())
    assert not summary.failed, summary.failed
    write_dashboard(out)  # as build-dataset does after the build
    return out


@pytest.fixture(scope="session")
def dyad_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """20 generated takes of two people talking in turn, paired, with a dyadic split
    (gesturebank.testing.dyads): the listener nods with the partner's speech."""
    from gesturebank.testing.dyads import write_dyad_dataset

    return write_dyad_dataset(tmp_path_factory.mktemp("dyads") / "ds", seconds=4.0)
