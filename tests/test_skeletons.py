"""Every skeleton's map to COCO-17 against the keypoint orders its authors publish.

The expected indices below are written from each format's documentation (OpenPose output
docs, MediaPipe pose landmarker docs, Halpe, Human3.6M/VideoPose3D), independently of the
name-based mapping in gesturebank.skeletons.
"""

import numpy as np
import pytest

from gesturebank.errors import InputError
from gesturebank.skeletons import COCO17, SKELETONS, get_skeleton, to_coco17

# COCO-17 order: nose, l_eye, r_eye, l_ear, r_ear, l_sho, r_sho, l_elb, r_elb, l_wri, r_wri,
# l_hip, r_hip, l_knee, r_knee, l_ank, r_ank. Value = source index, None = the format lacks it.
PUBLISHED = {
    "coco17": list(range(17)),
    "halpe26": list(range(17)),
    "blazepose33": [0, 2, 5, 7, 8, 11, 12, 13, 14, 15, 16, 23, 24, 25, 26, 27, 28],
    "body25": [0, 16, 15, 18, 17, 5, 2, 6, 3, 7, 4, 12, 9, 13, 10, 14, 11],
    "coco18": [0, 15, 14, 17, 16, 5, 2, 6, 3, 7, 4, 11, 8, 12, 9, 13, 10],
    "h36m17": [9, None, None, None, None, 11, 14, 12, 15, 13, 16, 4, 1, 5, 2, 6, 3],
}
SIZES = {"coco17": 17, "halpe26": 26, "blazepose33": 33, "body25": 25, "coco18": 18, "h36m17": 17}


def test_every_registered_skeleton_is_checked() -> None:
    assert set(SKELETONS) == set(PUBLISHED)


@pytest.mark.parametrize("name", sorted(PUBLISHED))
def test_map_to_coco17_puts_each_joint_where_published(name: str) -> None:
    skel = get_skeleton(name)
    assert len(skel) == SIZES[name]
    t = 3
    # Each source keypoint carries its own index, so the output says where it came from.
    pts = np.broadcast_to(np.arange(len(skel), dtype=np.float32)[None, :, None], (t, len(skel), 3))
    coco = to_coco17(pts, name)
    assert coco.shape == (t, 17, 3)
    for coco_index, src in enumerate(PUBLISHED[name]):
        if src is None:
            assert np.isnan(coco[:, coco_index]).all(), COCO17.joints[coco_index]
        else:
            assert (coco[:, coco_index] == src).all(), COCO17.joints[coco_index]


def test_wrong_keypoint_count_and_unknown_name() -> None:
    with pytest.raises(InputError, match="expected 25 keypoints"):
        to_coco17(np.zeros((2, 17, 3)), "body25")
    with pytest.raises(InputError, match="unknown skeleton 'openpose'"):
        get_skeleton("openpose")
