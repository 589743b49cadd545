"""The swap repair lets the take's usual facing decide only runs that look like a skeleton the
detector turned round (`repair.swaps._facing_explains`, issue 39): a run facing the unusual way
throughout, met by the usual facing on both sides, is such a skeleton (issue 41's test3.bvh at
0°); a real turn the detector followed, or the wrong side of a fast-motion jump, is not."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from gesturebank.repair.swaps import _facing_explains

USUAL, UNUSUAL, UNTOLD = 1.0, -1.0, 0.0


def _runs(n: int, *spans: tuple[int, int]) -> np.ndarray:
    flipped = np.zeros(n, dtype=bool)
    for a, b in spans:
        flipped[a:b] = True
    return flipped


def test_a_skeleton_turned_round_between_usual_frames_is_explained() -> None:
    facing = np.full(40, USUAL)
    facing[10:20] = UNUSUAL
    facing[[12, 17]] = UNTOLD  # side views: no facing told
    assert _facing_explains(_runs(40, (10, 20)), facing)
    assert _facing_explains(_runs(40), facing)  # nothing flipped: nothing to explain


def test_a_run_that_faces_the_usual_way_in_one_half_is_not_explained() -> None:
    """The end of a real turn: the detector faced the person away for the first half of the run
    and back for its second; flipping the whole run for the usual facing is wrong."""
    facing = np.full(40, USUAL)
    facing[10:15] = UNUSUAL
    assert not _facing_explains(_runs(40, (10, 20)), facing)
    assert _facing_explains(_runs(40, (10, 15)), facing)


def test_a_run_met_by_the_unusual_facing_is_not_explained() -> None:
    """A run inside a real turn (the person faces away before it too), or the wrong side of a
    jump: the nearest frame that tells the facing, past side views, faces the unusual way."""
    facing = np.full(40, USUAL)
    facing[4:20] = UNUSUAL
    facing[8:10] = UNTOLD
    assert not _facing_explains(_runs(40, (10, 20)), facing)
    facing[4:8] = USUAL  # the person faced the usual way before the side views
    assert _facing_explains(_runs(40, (10, 20)), facing)


def test_a_run_that_tells_no_facing_is_not_explained() -> None:
    facing = np.full(40, USUAL)
    facing[10:20] = UNTOLD
    assert not _facing_explains(_runs(40, (10, 20)), facing)


def test_every_run_must_be_explained() -> None:
    facing = np.full(60, USUAL)
    facing[10:20] = UNUSUAL
    facing[35:40] = UNUSUAL
    assert _facing_explains(_runs(60, (10, 20), (35, 40)), facing)
    assert not _facing_explains(_runs(60, (10, 20), (30, 40)), facing)


@given(
    facing=st.lists(st.sampled_from([USUAL, UNUSUAL, UNTOLD]), min_size=2, max_size=30),
    flipped=st.lists(st.booleans(), min_size=30, max_size=30),
)
def test_the_rule_reads_a_take_the_same_backwards(facing: list[float], flipped: list[bool]) -> None:
    """Nothing in the rule depends on the direction of time: a take played backwards is
    explained exactly when the take is."""
    f = np.array(facing)
    runs = np.array(flipped[: len(f)])
    assert _facing_explains(runs, f) == _facing_explains(runs[::-1], f[::-1])
