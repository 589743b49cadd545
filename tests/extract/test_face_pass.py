"""The face pass (issue 43): the real face landmark model on the face photo the renderer paints
(scikit-image's astronaut), fed frame by frame as the detector feeds it. A face alone is
followed from its last mesh, moved as the body's nose moved (one model pass a sample), and its
mouth is not read; with company, every face is found afresh and its mouth read; a face lost
from its followed crop is found afresh; frames come at most at the rate, on the detected
frames' own clock."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gesturebank.config import SpeechConfig
from gesturebank.extract import head_pose
from gesturebank.extract.detectors.blazepose import Roi
from gesturebank.extract.face_pass import FacePass, FaceWork
from gesturebank.extract.roles import sampled_frames
from gesturebank.skeletons import COCO17

HEAD = (2.75, 24.0)  # retarget.head_max_face_turn, head_min_face_px
EYES = {"right_eye": (33, 133), "left_eye": (263, 362)}  # outer and inner corners on the mesh


@pytest.fixture(scope="module")
def scene():
    """(the photo, COCO-17 keypoints of its face from one fresh mesh, that fresh head)."""
    from skimage import data

    from gesturebank.extract.mouth import FaceLandmarker

    photo = np.ascontiguousarray(data.astronaut())
    model = FaceLandmarker()
    mesh = model(photo, Roi(225.0, 124.0, 202.0, 0.0))
    kp = np.full((len(COCO17), 3), np.nan, np.float32)
    kp[COCO17.index["nose"]] = (*mesh.points[1], 0.9)
    for name, (a, b) in EYES.items():
        kp[COCO17.index[name]] = (*(mesh.points[a] + mesh.points[b]) / 2, 0.9)
    fresh = model(photo, head_pose.mesh_roi(mesh.points))
    return photo, kp, head_pose.fit_head(fresh.points3d).axes


def _apart_deg(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(Rotation.from_matrix(a.T @ b).magnitude()))


def test_a_face_alone_is_followed_and_its_mouth_is_not_read(scene) -> None:
    photo, kp, fresh = scene
    faces = FacePass(FaceWork(SpeechConfig(), True, HEAD, mouth_alone=False), skeleton="coco17")
    for i in range(3):
        faces(2 * i, i / 15, photo, kp[None], np.array([7]))
    assert faces.rows == [0, 2, 4]
    assert faces.passes == 2 + 1 + 1  # found afresh once, then followed
    for found in faces.faces:
        (face,) = found
        assert face.slot == 0 and np.isnan(face.opening)
        assert _apart_deg(face.axes, fresh) < 3.0


def test_with_company_every_face_is_found_afresh_and_its_mouth_read(scene) -> None:
    photo, kp, fresh = scene
    two = np.hstack([photo, photo])  # the same face twice, 512 px apart
    other = kp.copy()
    other[:, 0] += 512
    faces = FacePass(FaceWork(SpeechConfig(), True, HEAD, mouth_alone=False), skeleton="coco17")
    for i in range(2):
        faces(i, i / 15, two, np.stack([kp, other]), np.array([1, 2]))
    assert faces.passes == 2 * 2 * 2  # two faces, two frames, two passes each
    for found in faces.faces:
        assert [f.slot for f in found] == [0, 1]
        assert all(np.isfinite(f.opening) and _apart_deg(f.axes, fresh) < 3.0 for f in found)


def test_a_followed_face_moves_with_the_body_and_is_found_afresh_once_lost(scene) -> None:
    photo, kp, fresh = scene
    moved = np.roll(photo, 250, axis=1)  # further than the crop's half side
    there = kp.copy()
    there[:, 0] += 250
    faces = FacePass(FaceWork(SpeechConfig(), True, HEAD, mouth_alone=False), skeleton="coco17")
    faces(0, 0.0, photo, kp[None], np.array([3]))
    faces(1, 1 / 15, moved, there[None], np.array([3]))  # the crop moves as the body's nose
    assert faces.passes == 2 + 1
    assert _apart_deg(faces.faces[1][0].axes, fresh) < 3.0
    faces(2, 2 / 15, np.zeros_like(photo), there[None], np.array([3]))  # no face where it was
    assert faces.passes == 2 + 1 + 1 + 2  # the followed crop, then found afresh
    assert np.isnan(faces.faces[2][0].axes).all()  # no head: no face there either


def test_a_head_never_found_is_looked_for_less_often_until_it_is(scene) -> None:
    # a pixelated face (the talking demo's lab clip): two passes a sample found nothing
    photo, kp, fresh = scene
    blank = np.zeros_like(photo)
    faces = FacePass(FaceWork(SpeechConfig(), True, HEAD, mouth_alone=False), skeleton="coco17")
    passes = []
    for i in range(16):
        faces(i, i / 15, photo if 10 <= i < 12 else blank, kp[None], np.array([5]))
        passes.append(faces.passes)
    # 3 misses (2 passes each), 3 samples not looked at, a miss, 3 not looked at, then found
    # (2 passes) and followed (1 pass); once found, looked for on every sample again (the
    # followed crop, then afresh: 3 passes; then afresh: 2)
    assert passes == [2, 4, 6, 6, 6, 6, 8, 8, 8, 8, 10, 11, 14, 16, 18, 20]
    assert [len(f) for f in faces.faces] == [1, 1, 1, 0, 0, 0, 1, 0, 0, 0] + [1] * 6
    assert np.isnan(faces.faces[6][0].axes).all()
    assert all(_apart_deg(faces.faces[i][0].axes, fresh) < 3.0 for i in (10, 11))


def test_frames_come_at_most_at_the_rate_on_the_detected_frames_clock() -> None:
    # 60 fps footage detected at 30: every second detected frame at 15 Hz (before, the face
    # decode's own 15 Hz cap on the 60 fps frames met the detected ones on about half of them)
    detected = np.arange(60) / 30 + 1 / 60
    rows = sampled_frames(detected, 15.0)
    np.testing.assert_array_equal(rows, np.arange(0, 60, 2))
    faces = FacePass(FaceWork(SpeechConfig(), False, None), skeleton="coco17")
    empty = np.full((1, len(COCO17), 3), np.nan)
    for i, t in enumerate(detected[:5]):
        faces(i, float(t), np.zeros((4, 4, 3), np.uint8), empty, None)
    assert faces.rows == [0, 2, 4] and faces.passes == 0


def test_the_face_pass_during_detection_equals_the_second_decode(samples, tmp_path) -> None:
    """The first build of a video measures the faces on the frames as BlazePose detects them;
    a build whose detections come from the cache decodes the video again for them: the same
    heads and roles either way (sports2d's three people, its first 2.5 s: 36 heads measured)."""
    from gesturebank.app.extract import extract_take
    from gesturebank.config import Config
    from gesturebank.extract.cache import DetectionCache

    video = samples / "talking" / "outdoor" / "sports2d_arctic.mp4"
    config = Config.model_validate({"video": {"end_s": 2.5}})
    cache = DetectionCache(tmp_path)
    during, again = (extract_take(video, config, cache=cache) for _ in range(2))
    assert during.info.cache_hit is False and again.info.cache_hit is True
    assert during.heads is not None and again.heads is not None
    assert np.isfinite(during.heads.axes[..., 0, 0]).sum() >= 10
    np.testing.assert_array_equal(during.heads.axes, again.heads.axes)
    assert during.tracked.roles is not None and again.tracked.roles is not None
    np.testing.assert_array_equal(during.tracked.roles.role, again.tracked.roles.role)


def _sequence(scene):
    """32 frames at 30 fps (16 samples at 15 Hz) of a face missed, looked for less often, then
    found on 2 samples and followed."""
    photo, kp, _ = scene
    blank = np.zeros_like(photo)
    return [
        (i, i / 30, photo if 10 <= i < 14 else blank, kp[None], np.array([5])) for i in range(32)
    ]


def test_the_face_pass_beside_the_detector_measures_what_it_measures_in_line(scene) -> None:
    """Issue 43: the face pass of frame n runs in its own thread while the detector goes on to
    frame n + 1; the frames sampled, the passes and the heads are the ones measured in line."""
    from gesturebank.extract.face_beside import faces_beside

    work = FaceWork(SpeechConfig(), True, HEAD, mouth_alone=False)
    inline, beside = FacePass(work, skeleton="coco17"), FacePass(work, skeleton="coco17")
    for frame in _sequence(scene):
        inline(*frame)
    with faces_beside(beside) as hook:
        assert hook is not None
        for frame in _sequence(scene):
            hook(*frame)
    assert beside.rows == inline.rows == list(range(0, 32, 2))
    assert beside.passes == inline.passes
    assert any(np.isfinite(f.axes).all() for found in beside.faces for f in found)
    for a, b in zip(inline.faces, beside.faces, strict=True):
        assert [f.slot for f in a] == [f.slot for f in b]
        for f, g in zip(a, b, strict=True):
            np.testing.assert_array_equal(f.axes, g.axes)


class _Failing(FacePass):
    """A face pass whose model breaks on its third sample (as a missing model file would)."""

    def measure(self, index, image, keypoints, keys) -> None:
        if len(self.rows) == 2:
            raise RuntimeError("face model broke")
        self.rows.append(index)


def _detect(hook, frames: int, fail_at: int | None = None) -> None:
    for i in range(frames):
        if i == fail_at:
            raise KeyboardInterrupt  # Ctrl-C in the detector's thread
        hook(i, i / 15, np.zeros((4, 4, 3), np.uint8), np.zeros((1, 17, 3)), np.array([0]))


def _faces_threads() -> list:
    import threading

    return [t for t in threading.enumerate() if t.name == "faces"]


def _ends(run) -> BaseException | None:
    """What `run` raised, run in a thread that must end (a hang fails, not blocks, the test)."""
    import threading

    raised: list[BaseException | None] = [None]

    def target() -> None:
        try:
            run()
        except BaseException as exc:
            raised[0] = exc

    thread = threading.Thread(target=target)
    thread.start()
    thread.join(timeout=30)
    assert not thread.is_alive(), "the detection hangs on the face thread"
    return raised[0]


def test_a_failure_in_the_face_thread_stops_the_detection_with_its_error() -> None:
    from gesturebank.extract.face_beside import faces_beside

    faces = _Failing(FaceWork(SpeechConfig(), False, None), skeleton="coco17")

    def run() -> None:
        with faces_beside(faces) as hook:
            _detect(hook, 50)

    raised = _ends(run)
    assert isinstance(raised, RuntimeError) and str(raised) == "face model broke"
    assert faces.rows == [0, 1] and not _faces_threads()


def test_an_interrupted_detection_leaves_no_face_thread_behind() -> None:
    from gesturebank.extract.face_beside import faces_beside

    faces = _Failing(FaceWork(SpeechConfig(), False, None), skeleton="coco17")

    def run() -> None:
        with faces_beside(faces) as hook:
            _detect(hook, 50, fail_at=1)

    assert isinstance(_ends(run), KeyboardInterrupt)
    assert faces.rows in ([], [0]) and not _faces_threads()  # frame 0 measured or dropped
