"""The face pass in its own thread, beside the detector (issue 43).

The tracker must finish frame n before frame n + 1 (its crops come from frame n's landmarks), but
the face pass of frame n needs only frame n's image and people. Run in the detector's thread it
left the second core to decoding alone while the face model ran; here it runs in a thread of its
own ("faces") while the detector goes on to the next frames. The frames it measures and the order
it measures them in are the same (the rate's clock is kept on the detector's side, the faces are
measured in order by one thread), so the outputs are too.

At most one sampled frame is handed over at a time: the detector waits for the face thread to be
done with the sample before (`waited_s`, the face pass's share of the detection's wall time), so
a worker holds at most one frame more than before (25 MB at 4K UHD). An error in the face thread
stops the detection at the next sampled frame (or at the end) and is raised there, as it was
when the face pass ran in line; the face thread always drains what it is handed, so nothing
waits on it for ever.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

from gesturebank.extract.face_pass import FacePass

_Item = tuple[int, np.ndarray, np.ndarray, np.ndarray | None]


class FacesBeside:
    """`faces` (a `FacePass`) fed from the detector's thread and measured in its own; call it as
    the detector's `on_people` hook, then `close` (or `abandon` when the detection failed)."""

    def __init__(self, faces: FacePass) -> None:
        self.faces = faces
        self.waited_s = 0.0  # the detector's seconds spent waiting for the face thread
        self._idle = threading.Semaphore(1)  # released when the face thread is done with a sample
        self._work: queue.SimpleQueue[_Item | None] = queue.SimpleQueue()
        self._error: BaseException | None = None
        self._drop = False  # abandoned: what is handed over is no longer measured
        self._thread = threading.Thread(target=self._run, name="faces", daemon=True)
        self._thread.start()

    def __call__(
        self,
        index: int,
        t: float,
        image: np.ndarray,
        keypoints: np.ndarray,
        keys: np.ndarray | None,
    ) -> None:
        """As `FacePass.__call__`, the measuring done in the face thread."""
        if not self.faces.take(t):
            return
        start = time.perf_counter()
        self._idle.acquire()  # the sample before is measured: one frame held beside the detector's
        self.waited_s += time.perf_counter() - start
        if self._error is not None:
            self._idle.release()
            raise self._error
        self._work.put((index, image, keypoints, keys))

    def _run(self) -> None:
        while (item := self._work.get()) is not None:
            try:
                if self._error is None and not self._drop:
                    self.faces.measure(*item)
            except BaseException as exc:  # raised in the detector's thread
                self._error = exc
            finally:
                item = None  # the frame is not held while the next one is awaited
                self._idle.release()

    def close(self) -> None:
        """Wait for the last sample to be measured; raise the face thread's error, if any."""
        start = time.perf_counter()
        self._work.put(None)
        self._thread.join()
        self.waited_s += time.perf_counter() - start
        if self._error is not None:
            raise self._error

    def abandon(self) -> None:
        """Stop without measuring what waits (the detection failed or was interrupted)."""
        self._drop = True
        self._work.put(None)
        self._thread.join()


@contextmanager
def faces_beside(faces: FacePass | None) -> Iterator[FacesBeside | None]:
    """A `FacesBeside` for `faces` (None: None), closed on the way out: every sample measured,
    or, when the block raised, abandoned."""
    if faces is None:
        yield None
        return
    beside = FacesBeside(faces)
    try:
        yield beside
    except BaseException:
        beside.abandon()
        raise
    beside.close()
