"""Issue 41: a waist-up speaker whose mouth cannot be read (the demo blurred his face; the speech
is dubbed) with a much smaller person standing far behind him is the speaker, role unknown: the
person behind does not veto him (Pose2Sim Demo_SinglePerson cam02, `footage` "behind")."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gesturebank import footage
from gesturebank.app.extract import extract_take
from gesturebank.config import Config
from gesturebank.datasets import open as open_dataset
from gesturebank.extract import roles as R
from tests.datasets.test_real_footage import build


def test_a_speaker_with_a_small_person_behind_is_kept_with_role_unknown(
    samples: Path, tmp_path: Path
) -> None:
    made = footage.make_footage(
        samples, samples.parent / "footage" / "scale1", time_scale=1.0, names=["behind"]
    )
    video = made["behind"]
    ext = extract_take(video, Config())
    assert (ext.multi.present.sum(axis=1) >= 2).mean() > 0.8  # the person behind is found
    choices = ext.tracked.report.choices
    print("\nbehind: " + "; ".join(f"{c.reason} {c.main_id} {c.scores}" for c in choices))
    main = ext.tracked.report.main_ids
    assert (main >= 0).mean() > 0.95
    sizes = {k: v["size"] for k, v in choices[0].scores.items()}
    assert sizes[int(np.bincount(main[main >= 0]).argmax())] == 1.0  # the big one, in front
    ds = open_dataset(build({"behind": video}, tmp_path))
    kept = sum(r.clip.duration_s for r in ds.clips("accepted"))
    seconds = sum(r.take.seconds for r in ds.clips(None)[:1])
    print(f"behind: kept {kept:.1f} of {seconds:.1f} s")
    assert kept >= 0.9 * seconds, [r.clip.qc_reasons for r in ds.rows()]
    clip = ds.load(ds.clip_ids("accepted")[0])
    assert (np.asarray(clip.role) == R.UNKNOWN).all()
