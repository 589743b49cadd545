"""The benchmarks' `--quick` runs for tests/test_benchmarks.py, started in the background when
the session starts (tests/conftest.py), one at a time.

The suite keeps about one of the two cores busy on average, so the runs (~2.5 min in all) mostly
take the idle one; their tests come at three quarters of the suite and read the finished runs.
Selected alone, the tests wait for the runs in their own order: as long as running them there.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from collections.abc import Iterable
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TIMEOUT_S = 900  # a guard against a hang, not a speed requirement

# Run when their test comes, not beside the suite: scale.py starts a private Ray, which the
# cluster tests' `--ray-address auto` could find.
IN_ITS_TURN = frozenset({"scale.py"})


class QuickRuns:
    """`script --quick` for the scripts given, each run once, as a user would run it."""

    def __init__(self, scripts: Iterable[Path], samples: Path) -> None:
        self.samples = samples
        # UTF-8 out, so rich draws its box characters rather than an ASCII fallback.
        self._env = os.environ | {"GESTUREBANK_SAMPLES": str(samples), "PYTHONIOENCODING": "utf-8"}
        self._procs: list[subprocess.Popen[str]] = []
        self.seconds: dict[str, float] = {}  # each finished run's wall time (the session's report)
        self._lock = threading.Lock()
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="quick-benchmarks")
        self._runs: dict[str, Future[subprocess.CompletedProcess[str]]] = {
            s.name: self._pool.submit(self._run, s) for s in scripts if s.name not in IN_ITS_TURN
        }

    def result(self, script: Path) -> subprocess.CompletedProcess[str]:
        """The finished run of `script` (waited for; run now when it was not started)."""
        run = self._runs.get(script.name)
        return run.result() if run is not None else self._run(script)

    def close(self) -> None:
        """Runs not started are dropped; running ones are killed (a session cut short)."""
        self._pool.shutdown(wait=False, cancel_futures=True)
        with self._lock:
            for proc in self._procs:
                if proc.poll() is None:
                    proc.kill()

    def _run(self, script: Path) -> subprocess.CompletedProcess[str]:
        args = [sys.executable, str(script), "--quick"]
        start = time.perf_counter()
        proc = subprocess.Popen(
            args,
            cwd=ROOT,
            env=self._env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            encoding="utf-8",
        )
        with self._lock:
            self._procs.append(proc)
        try:
            out, err = proc.communicate(timeout=TIMEOUT_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            raise
        self.seconds[script.name] = time.perf_counter() - start
        return subprocess.CompletedProcess(args, proc.returncode, out, err)

    def report(self) -> str:
        """The runs' wall times, slowest first (pytest's durations show only the waits)."""
        runs = sorted(self.seconds.items(), key=lambda kv: -kv[1])
        return ", ".join(f"{name} {s:.1f} s" for name, s in runs)
