from pathlib import Path

import numpy as np
import pytest

from gesturebank.errors import InputError
from gesturebank.poses import MultiPose2D, Pose2D, Pose3D


def make2d(t: int = 5, skeleton: str = "coco17", k: int = 17) -> Pose2D:
    rng = np.random.default_rng(0)
    kp = np.concatenate([rng.uniform(0, 640, (t, k, 2)), rng.uniform(0, 1, (t, k, 1))], axis=-1)
    kp[1, 3] = np.nan  # a missing keypoint
    return Pose2D(kp, np.cumsum(rng.uniform(0.01, 0.05, t)), skeleton, (640, 480))


def make3d(t: int = 5) -> Pose3D:
    rng = np.random.default_rng(1)
    joints = rng.normal(size=(t, 17, 3))
    joints[:, 13:] = np.nan  # legs missing
    conf = rng.uniform(size=(t, 17))
    conf[:, 13:] = np.nan
    return Pose3D(joints, conf, np.arange(t) / 30.0, frame="camera", units="m", meta={"by": "x"})


def test_pose2d_coerces_dtypes() -> None:
    p = make2d()
    assert p.keypoints.dtype == np.float32
    assert p.timestamps.dtype == np.float64
    assert p.image_size == (640, 480)
    assert p.xy.shape == (5, 17, 2)
    assert p.confidence.shape == (5, 17)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"keypoints": np.zeros((5, 16, 3))}, r"\(T, 17, 3\)"),
        ({"keypoints": np.zeros((5, 17, 2))}, r"\(T, 17, 3\)"),
        ({"timestamps": np.array([0, 1, 1, 2, 3.0])}, "strictly increasing"),
        ({"timestamps": np.arange(4.0)}, r"shape \(5,\)"),
        ({"timestamps": np.array([0, 1, np.nan, 2, 3])}, "finite"),
        ({"image_size": (0, 480)}, "image_size"),
        ({"skeleton": "nope"}, "unknown skeleton"),
    ],
)
def test_pose2d_rejects_bad_input(change: dict, message: str) -> None:
    p = make2d()
    kwargs = {
        "keypoints": p.keypoints,
        "timestamps": p.timestamps,
        "skeleton": "coco17",
        "image_size": (640, 480),
    }
    kwargs.update(change)
    with pytest.raises(InputError, match=message):
        Pose2D(**kwargs)


def test_pose2d_rejects_half_missing_and_bad_confidence() -> None:
    kp = make2d().keypoints.copy()
    kp[0, 0, 0] = np.nan
    with pytest.raises(InputError, match="x or y"):
        Pose2D(kp, np.arange(5.0), "coco17", (640, 480))
    kp = make2d().keypoints.copy()
    kp[0, 0, 2] = 1.5
    with pytest.raises(InputError, match=r"\[0, 1\]"):
        Pose2D(kp, np.arange(5.0), "coco17", (640, 480))


def test_pose2d_npz_round_trip(tmp_path: Path) -> None:
    p = make2d(skeleton="blazepose33", k=33)
    p = Pose2D(p.keypoints, p.timestamps, p.skeleton, p.image_size, world=p.keypoints * 0.01)
    p.save(tmp_path / "p.npz")
    q = Pose2D.load(tmp_path / "p.npz")
    np.testing.assert_array_equal(q.keypoints, p.keypoints)  # NaNs included
    np.testing.assert_array_equal(q.timestamps, p.timestamps)
    np.testing.assert_array_equal(q.world, p.world)
    assert (q.skeleton, q.image_size) == ("blazepose33", (640, 480))


def test_multipose2d_stores_a_pose2d_s_arrays_and_its_ids() -> None:
    p = make2d(skeleton="blazepose33", k=33)
    p = Pose2D(p.keypoints, p.timestamps, p.skeleton, p.image_size, world=p.keypoints * 0.01)
    one = MultiPose2D.from_pose2d(p)
    ids = np.arange(len(p))[:, None]
    multi = MultiPose2D(one.keypoints, one.timestamps, one.skeleton, one.image_size, one.world, ids)
    arrays = multi.to_arrays()
    assert list(arrays) == [*p.to_arrays(), "ids"]  # one format: the same names, in one order
    back = MultiPose2D.from_arrays(arrays)
    np.testing.assert_array_equal(back.ids, ids)
    np.testing.assert_array_equal(back.slot(0).keypoints, p.keypoints)  # NaNs included
    np.testing.assert_array_equal(back.slot(0).world, p.world)
    np.testing.assert_array_equal(back.timestamps, p.timestamps)
    assert (back.skeleton, back.image_size) == ("blazepose33", (640, 480))


def test_pose2d_to_coco17_keeps_named_joints() -> None:
    p = make2d(skeleton="blazepose33", k=33)
    c = p.to_coco17()
    assert c.skeleton == "coco17"
    # BlazePose index 11 is the left shoulder; COCO-17 index 5 is the left shoulder
    np.testing.assert_array_equal(c.keypoints[:, 5], p.keypoints[:, 11])


def test_pose3d_validation_and_round_trip(tmp_path: Path) -> None:
    p = make3d()
    p.save(tmp_path / "p.npz")
    q = Pose3D.load(tmp_path / "p.npz")
    np.testing.assert_array_equal(q.joints, p.joints)
    np.testing.assert_array_equal(q.confidence, p.confidence)
    assert (q.frame, q.units, q.meta) == ("camera", "m", {"by": "x"})
    np.testing.assert_array_equal(q.joint("left_wrist"), p.joints[:, 9])
    with pytest.raises(InputError, match=r"\(T, 17, 3\)"):
        Pose3D(np.zeros((3, 25, 3)), np.zeros((3, 25)), np.arange(3.0))
    with pytest.raises(InputError, match="confidence must have shape"):
        Pose3D(np.zeros((3, 17, 3)), np.zeros((3, 16)), np.arange(3.0))
    bad = np.zeros((3, 17, 3))
    bad[0, 0, 1] = np.nan
    with pytest.raises(InputError, match="some coordinates missing"):
        Pose3D(bad, np.zeros((3, 17)), np.arange(3.0))
    with pytest.raises(InputError, match="units"):
        Pose3D(np.zeros((3, 17, 3)), np.zeros((3, 17)), np.arange(3.0), units="mm")  # type: ignore[arg-type]


def test_load_never_unpickles_and_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "evil.npz"
    np.savez(path, joints=np.array([object()], dtype=object))
    with pytest.raises(InputError, match="evil.npz"):
        Pose3D.load(path)
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip")
    with pytest.raises(InputError, match="junk.npz"):
        Pose2D.load(junk)
