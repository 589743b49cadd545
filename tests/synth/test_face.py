"""The face photo is painted where the truth's face points are, so a detector's eye keypoints
can be scored against the truth's (the head error of the truth benchmarks is the detector's)."""

from __future__ import annotations

import numpy as np
import pytest

from gesturebank.mocap.names import face_model
from gesturebank.synth.looks import LOOKS, face_colours

LUMA = np.array([0.299, 0.587, 0.114])


@pytest.mark.parametrize("look", sorted(LOOKS))
@pytest.mark.parametrize("eye", ["left_eye", "right_eye"])
def test_the_photos_pupils_are_at_the_truths_eyes(look: str, eye: str) -> None:
    model = face_model()
    # face_colours takes (left, up) from the eyes' midpoint, at the ears' height (figure.py).
    _, up, left = np.subtract(model[eye], (0.0, model["left_ear"][1], 0.0))
    assert up == 0.0  # the face model has its eyes at the ears' height (HeadPitch 0 when level)
    grid = np.linspace(-0.02, 0.02, 81)  # 2 cm around it, 0.5 mm steps
    lefts, ups = (a.ravel() for a in np.meshgrid(left + grid, up + grid))
    luma = face_colours(lefts, ups, look=LOOKS[look], mouth=np.zeros(len(lefts))) @ LUMA
    darkest = int(np.argmin(luma))
    assert np.hypot(lefts[darkest] - left, ups[darkest] - up) < 0.005  # measured: 2.7–2.8 mm
