"""Mouth opening per frame from a face crop, and how well it follows the speech (who speaks).

The face crop is a square, rotated upright along the eye line, placed from the pose's face
keypoints (nose and eyes); faces too small or turned away get none. The face landmark model
mediapipe 0.10.14 bundles (`modules/face_landmark/face_landmark.tflite`: 192×192 RGB in [0, 1],
468 canonical face-mesh points and a face-presence logit) runs on it in ai-edge-litert, as the
BlazePose detector's models do. Opening = |p13 − p14| / |p10 − p152| (inner lip centres over
forehead-to-chin), so neither the face's size in the image nor the crop matters.

The speaking score is a sliding-window correlation of the mouth-opening speed with the speech
envelope's rate of change, the mouth allowed to lag the speech: a speaker's mouth opens as the
sound rises and closes as it falls; a listener's mouth is mostly still, and when it moves it does
not follow. (The unsigned speed against the envelope itself separates poorly: a mouth copying the
envelope 133 ms late with noise scored a median 0.29-0.44, a random mouth 0.04-0.22.)
"""

from __future__ import annotations

import importlib.util
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from gesturebank.config import SpeechConfig
from gesturebank.errors import DetectionError
from gesturebank.extract.detectors.blazepose import Roi, load_interpreter, sigmoid, warp
from gesturebank.extract.detectors.mediapipe import INSTALL
from gesturebank.skeletons import COCO17, get_skeleton

FACE_MODEL = Path("modules") / "face_landmark" / "face_landmark.tflite"
FACE_SIZE = 192  # the model's input side, pixels
UPPER_LIP, LOWER_LIP = 13, 14  # inner lip centres on the canonical face mesh
FOREHEAD, CHIN = 10, 152
# Crop side over the face width: a face is about 1.3 widths high, and mediapipe's
# face-landmark crop is the face box enlarged 1.5 times; 2 widths holds forehead to chin.
CROP_PER_WIDTH = 2.0
# Face width over eye-to-eye distance (adult faces: about 145 mm over 63 mm).
WIDTH_PER_EYES = 2.3
MIN_FACE_PRESENCE = 0.5  # the model's face-presence probability below which a crop has no face
_MIN_PAIRS = 6  # fewest frames a window's correlation is computed on
FACE_POINTS = ("nose", "left_eye", "right_eye")


def face_model_path() -> Path:
    """The installed mediapipe wheel's face landmark .tflite (mediapipe is never imported)."""
    spec = importlib.util.find_spec("mediapipe")
    if spec is None or not spec.submodule_search_locations:
        raise DetectionError(f"mouth activity needs the mediapipe wheel's models: {INSTALL}")
    path = Path(next(iter(spec.submodule_search_locations))) / FACE_MODEL
    if not path.is_file():
        raise DetectionError(f"{path}: face landmark model missing from mediapipe: {INSTALL}")
    return path


def face_box(
    *, keypoints: np.ndarray, skeleton: str, config: SpeechConfig
) -> tuple[Roi | None, str]:
    """The square face crop of one person in one frame, or None with the reason.

    keypoints: (K, 3) x px, y px, confidence in `skeleton` order. The face must show its nose and
    both eyes (confidence ≥ min_face_confidence) with its left eye on the image's right (a head
    seen from behind has them swapped). Its turn is the nose's offset from the eye midpoint along
    the eye line over half the eye distance, about tan(yaw) (the nose tip stands about as far in
    front of the eyes as they are apart from the midline); it must be at most max_face_turn. Its
    width, WIDTH_PER_EYES × eye distance × √(1 + turn²) (undoing the turn's foreshortening), must
    be at least min_face_px. The ears are not used: on a turned face BlazePose places the hidden
    ear on the nose (Pose2Sim Demo_MultiPerson cam03). The crop is centred on the nose,
    CROP_PER_WIDTH widths wide, turned so the eyes are level in it."""
    coco = get_skeleton(skeleton).convert(np.asarray(keypoints)[None], COCO17)[0]
    pt = [coco[COCO17.index[name]] for name in FACE_POINTS]
    if not all(np.isfinite(p[0]) and p[2] >= config.min_face_confidence for p in pt):
        return None, "face unseen"
    nose, left_eye, right_eye = (p[:2].astype(np.float64) for p in pt)
    eye_line = left_eye - right_eye  # image x grows toward the person's left when facing us
    if eye_line[0] <= 0:
        return None, "facing away"
    eyes = float(np.hypot(*eye_line))
    turn = abs(float(np.dot(nose - (left_eye + right_eye) / 2, eye_line))) / (eyes * eyes / 2)
    if turn > config.max_face_turn:
        return None, "facing away"
    width = WIDTH_PER_EYES * eyes * float(np.sqrt(1 + turn * turn))
    if width < config.min_face_px:
        return None, "face too small"
    angle = float(np.arctan2(eye_line[1], eye_line[0]))
    return Roi(float(nose[0]), float(nose[1]), CROP_PER_WIDTH * width, angle), ""


@dataclass(frozen=True)
class FaceMesh:
    """One face-landmark pass: points (468, 2) image px, presence probability, mouth opening;
    points3d (468, 3): the same with the model's depth (scaled like x and y, away from the
    camera), for the head's pose (`extract.head_pose`)."""

    points: np.ndarray
    presence: float
    opening: float
    points3d: np.ndarray


class FaceLandmarker:
    """The face landmark model on face crops (one interpreter, reused)."""

    def __init__(self) -> None:
        interpreter: Any = load_interpreter(face_model_path(), 1)  # one small crop at a time
        self._interpreter = interpreter
        self._input = interpreter.get_input_details()[0]["index"]
        outputs = {d["name"]: d for d in interpreter.get_output_details()}
        # The 1404-wide output is the mesh (468 × x, y, z); the 1-wide one the presence logit.
        self._mesh = next(d["index"] for d in outputs.values() if d["shape"][-1] == 1404)
        self._flag = next(d["index"] for d in outputs.values() if d["shape"][-1] == 1)

    def __call__(self, image: np.ndarray, roi: Roi) -> FaceMesh:
        """Landmarks of the face in `roi` of the RGB uint8 `image`."""
        to_image = roi.crop_transform(FACE_SIZE)
        crop = warp(image, to_image, size=FACE_SIZE, border=cv2.BORDER_REPLICATE) / 255.0
        self._interpreter.set_tensor(self._input, crop[None].astype(np.float32))
        self._interpreter.invoke()
        mesh = self._interpreter.get_tensor(self._mesh).reshape(468, 3).astype(np.float64)
        presence = float(sigmoid(self._interpreter.get_tensor(self._flag).ravel()[0]))
        opening = mouth_opening(mesh)
        points = mesh[:, :2] @ to_image[:, :2].T + to_image[:, 2]
        depth = mesh[:, 2:] * np.sqrt(abs(np.linalg.det(to_image[:, :2])))  # crop px → image px
        return FaceMesh(points, presence, opening, np.concatenate([points, depth], axis=1))


def mouth_opening(points: np.ndarray) -> float:
    """|p13 − p14| / |p10 − p152| of face-mesh `points (468, ≥2)` in any one similar frame."""
    p = np.asarray(points, np.float64)[:, :2]
    face = float(np.hypot(*(p[FOREHEAD] - p[CHIN])))
    return float(np.hypot(*(p[UPPER_LIP] - p[LOWER_LIP]))) / face if face > 0 else float("nan")


def mouth_openings(
    frames: Iterable[np.ndarray], *, keypoints: np.ndarray, skeleton: str, config: SpeechConfig
) -> np.ndarray:
    """(T,) mouth opening of one person over `frames` (an iterable of T RGB uint8 images, one per
    row of `keypoints (T, K, 3)`); NaN where the face gets no crop or the model finds none."""
    model = FaceLandmarker()
    out = np.full(len(keypoints), np.nan)
    for i, image in enumerate(frames):
        roi, _ = face_box(keypoints=keypoints[i], skeleton=skeleton, config=config)
        if roi is not None:
            mesh = model(image, roi)
            if mesh.presence >= MIN_FACE_PRESENCE:
                out[i] = mesh.opening
    return out


def _correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson r of the finite pairs of `a` and `b`; NaN when too few or either is flat."""
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < _MIN_PAIRS:
        return float("nan")
    x, y = a[ok] - a[ok].mean(), b[ok] - b[ok].mean()
    denom = float(np.sqrt(np.dot(x, x) * np.dot(y, y)))
    return float(np.dot(x, y)) / denom if denom > 1e-12 else float("nan")


def speaking_score(
    *, opening: np.ndarray, envelope: np.ndarray, rate_hz: float, config: SpeechConfig
) -> np.ndarray:
    """(T,) how well the mouth follows the speech, per frame, in [−1, 1].

    opening: (T,) mouth opening (NaN where unmeasured) and envelope: (T,) speech envelope, both
    on one uniform clock of `rate_hz`. Frame t's score is the largest Pearson correlation, over
    lags 0..speaking_max_lag_s (mouth behind the speech), of the mouth-opening speed
    d opening/dt with the envelope's d envelope/dt, in the speaking_window_s window centred on t.
    NaN where the window holds too few measured frames or either signal is flat (no speech, or a
    mouth never measured: nothing to follow). 0 where the mouth is still (its opening spans less
    than still_mouth_range in the window): the landmark jitter of a closed mouth correlates with
    anything by chance (cam04's silent woman against unrelated speech: median 0.46 without it)."""
    opening = np.asarray(opening, np.float64)
    envelope = np.asarray(envelope, np.float64)
    n = len(opening)
    speed = np.full(n, np.nan)
    change = np.full(n, np.nan)
    if n >= 2:
        speed = np.gradient(opening) * rate_hz
        change = np.gradient(envelope) * rate_hz
    half = max(1, round(config.speaking_window_s * rate_hz / 2))
    lags = range(round(config.speaking_max_lag_s * rate_hz) + 1)
    score = np.full(n, np.nan)
    for t in range(n):
        lo, hi = max(0, t - half), min(n, t + half + 1)
        window = opening[lo:hi]
        if np.isfinite(window).sum() >= _MIN_PAIRS:
            p10, p90 = np.nanpercentile(window, [10, 90])
            if p90 - p10 < config.still_mouth_range:
                score[t] = 0.0
                continue
        best = -np.inf
        for lag in lags:  # speed at frame i against the envelope at frame i − lag
            start = max(lo, lag)
            if hi - start >= _MIN_PAIRS:
                r = _correlation(speed[start:hi], change[start - lag : hi - lag])
                best = max(best, r) if np.isfinite(r) else best
        score[t] = best if np.isfinite(best) else np.nan
    return score
