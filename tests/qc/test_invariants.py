"""Invariants of a written clip: each violation injected into a clean clip is found, with a
reason that names the invariant and the frame; a frozen robot is rejected, reach is not."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from gesturebank.config import QCConfig
from gesturebank.qc.checks import absolute_reasons
from gesturebank.qc.metrics import clip_metrics
from gesturebank.robot import pepper
from gesturebank.testing.clips import clip_from_angles, synthetic_clip

PROFILE = pepper.load_profile()
J = pepper.INDEX["RShoulderPitch"]
FRAME = 150


def _reasons(clip) -> list[str]:
    return absolute_reasons(clip_metrics(clip, profile=PROFILE, qc=QCConfig()), QCConfig())


def _jump(clip):
    """RShoulderPitch from one limit to the other from frame FRAME on (a wrap, then a clamp)."""
    a = clip.angles.copy()
    a[FRAME:, J] = PROFILE.upper[J] if a[FRAME - 1, J] < 0 else PROFILE.lower[J]
    return replace(clip, angles=a, angles01=pepper.normalise(a, PROFILE).astype(np.float32))


def _unmasked_nan(clip):
    a = clip.angles.copy()
    a[FRAME, J] = np.nan
    return replace(clip, angles=a, angles01=pepper.normalise(a, PROFILE).astype(np.float32))


def _outside(clip):
    a = clip.angles.copy()
    a[FRAME:, J] = a[FRAME:, J] * 0 + PROFILE.upper[J] + 0.01  # just past: not a fast step
    a[FRAME - 20 : FRAME, J] = np.linspace(a[FRAME - 21, J], PROFILE.upper[J] - 0.01, 20)
    return replace(clip, angles=a, angles01=pepper.normalise(a, PROFILE).astype(np.float32))


def _stale_angles01(clip):
    a01 = clip.angles01.copy()
    a01[FRAME, J] += 0.1
    return replace(clip, angles01=a01)


def _audio_nan(clip):
    audio = clip.audio.copy()
    audio[FRAME, 3] = np.inf
    return replace(clip, audio=audio)


def _audio_short(clip):
    """Audio cut short (the Clip type refuses it, so it is forced past the type's check: the
    builder's own check must still find it in a clip written by other code)."""
    object.__setattr__(clip := replace(clip), "audio", clip.audio[:FRAME])
    return clip


def _jerkier(clip):
    """Processed angles with 6 Hz wobble the raw angles do not have (processing adding motion)."""
    a = clip.angles.astype(np.float64)
    wobble = 0.05 * np.sin(2 * np.pi * 8.0 * clip.times)
    a[:, J] = np.clip(a[:, J] + wobble, PROFILE.lower[J], PROFILE.upper[J])
    a = a.astype(np.float32)
    return replace(clip, angles=a, angles01=pepper.normalise(a, PROFILE).astype(np.float32))


@pytest.mark.parametrize(
    ("inject", "text"),
    [
        (_jump, f"invariant speed broken at frame {FRAME}: RShoulderPitch steps"),
        (_unmasked_nan, f"invariant mask broken at frame {FRAME}"),
        (_outside, "invariant limits broken at frame"),
        (_stale_angles01, f"invariant angles01 broken at frame {FRAME}"),
        (_audio_nan, f"invariant audio broken at frame {FRAME}: features not finite"),
        (_audio_short, f"invariant audio broken at frame {FRAME}: {FRAME} audio frames for"),
        (_jerkier, "invariant jerk broken (largest at frame"),
    ],
)
def test_each_invariant_violation_is_found_with_its_frame(inject, text) -> None:
    clip = synthetic_clip(seconds=4.0, seed=3)
    assert _reasons(clip) == []
    reasons = _reasons(inject(clip))
    assert any(r.startswith(text) for r in reasons), reasons


def test_outside_the_limits_names_the_first_frame() -> None:
    clip = synthetic_clip(seconds=4.0, seed=3)
    (reason,) = [r for r in _reasons(_outside(clip)) if "limits" in r]
    assert reason == f"invariant limits broken at frame {FRAME}: RShoulderPitch outside its limits"


def _elbow_beyond(past: float, wave: float, seconds: float):
    """A clip whose right elbow is bent `past` rad past RElbowRoll's limit, waving by ±`wave`
    rad there for `seconds` (0.5 s ramps in and out), the rest inside the limits."""
    ts = np.arange(0, seconds + 2.0, 1 / 30)
    angles = np.tile(pepper.neutral_pose(), (len(ts), 1))
    angles[:, pepper.INDEX["HeadYaw"]] = 0.3 * np.sin(2 * np.pi * 0.4 * ts)  # a live pose
    j = pepper.INDEX["RElbowRoll"]
    beyond = (ts >= 1.0) & (ts < 1.0 + seconds)
    ramp = np.clip(np.minimum(ts - 0.5, seconds + 1.5 - ts) / 0.5, 0, 1)
    angles[:, j] = 0.6 + ramp * (PROFILE.upper[j] + past - 0.6)
    angles[beyond, j] += wave * np.sin(2 * np.pi * 1.0 * (ts[beyond] - 1.0))
    return clip_from_angles(angles, ts, clip_id="frozen__c000")


def test_a_robot_frozen_at_a_limit_is_rejected_but_motion_beyond_reach_is_not() -> None:
    """Beyond reach for 3 s while the person's elbow waves ±0.3 rad: the robot stands within
    0.02 rad of the limit the whole time (frozen) → rejected with that reason. The same elbow
    held still beyond reach, or waving beyond it for only 1 s, is kept (the soft reach map
    holds within 0.02 rad from about 0.3 rad past this limit on)."""
    frozen = _reasons(_elbow_beyond(0.8, 0.3, 3.0))
    assert any(r.startswith("robot frozen at a limit: RElbowRoll held") for r in frozen), frozen
    assert _reasons(_elbow_beyond(0.45, 0.0, 3.0)) == []
    assert _reasons(_elbow_beyond(0.8, 0.3, 1.0)) == []


def test_gesturebank_qc_applies_the_invariants_to_the_clips_a_folder_holds(tmp_path) -> None:
    """A clip whose stored angles were broken after the build (a jump across RShoulderPitch's
    range) is measured again from its arrays by `gesturebank qc` and rejected, with the reason;
    the others stay accepted."""
    import subprocess
    import sys
    from pathlib import Path

    import pyarrow.parquet as pq

    from gesturebank.datasets import store
    from gesturebank.testing.clips import write_dataset

    takes = {f"s{i}_take": [synthetic_clip(seed=i, clip_id=f"s{i}_take__c000")] for i in range(3)}
    out = write_dataset(tmp_path / "ds", takes)
    path = store.clip_npz(out, take_id="s1_take", clip_id="s1_take__c000")
    with np.load(path) as d:
        arrays = {k: d[k] for k in d.files}
    broken = _jump(synthetic_clip(seed=1, clip_id="s1_take__c000"))
    arrays["angles"], arrays["angles01"] = broken.angles, broken.angles01
    np.savez(path, **arrays)
    gesturebank = Path(sys.executable).parent / "gesturebank"
    r = subprocess.run([str(gesturebank), "qc", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    rows = {c["clip_id"]: c for c in pq.read_table(out / "manifest.parquet").to_pylist()}
    assert rows["s0_take__c000"]["qc_status"] == rows["s2_take__c000"]["qc_status"] == "accepted"
    assert rows["s1_take__c000"]["qc_status"] == "rejected"
    assert any(
        r.startswith(f"invariant speed broken at frame {FRAME}: RShoulderPitch")
        for r in rows["s1_take__c000"]["qc_reasons"]
    ), rows["s1_take__c000"]["qc_reasons"]
