"""An executor that runs at once, in the caller's thread: put in place of a thread pool, it
shows what the pool buys (benchmarks/build.py's "in line" row) and that running beside gives
the same results (tests/extract/test_blazepose.py)."""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future
from typing import Any


class InLineExecutor:
    """`ThreadPoolExecutor`'s `submit` and context manager, with nothing run beside."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        pass

    def submit(self, fn: Callable[..., Any], *args: Any) -> Future:
        done: Future = Future()
        done.set_result(fn(*args))
        return done

    def __enter__(self) -> InLineExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        pass
