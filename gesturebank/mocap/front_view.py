"""The 2D view drawn for a motion-capture take: what its cut and 2D checks judge."""

from __future__ import annotations

import numpy as np

from gesturebank.poses import Pose2D, Pose3D
from gesturebank.skeletons import COCO17

MOCAP_PX_PER_M = 400.0  # the front view drawn for a mocap take (QC, dashboard), pixels per metre


def front_view(pose3d: Pose3D) -> Pose2D:
    """A mocap take seen by an orthographic camera in front of the speaker (their mean facing
    direction), image y down; the frame fits the body. The 2D checks (facing away, sideways,
    swaps) then judge the motion as they judge a video's."""
    from gesturebank.mocap.pose import body_axes

    _, left, up = body_axes(pose3d.joints)
    xy = np.stack([pose3d.joints @ left, -(pose3d.joints @ up)], axis=-1) * MOCAP_PX_PER_M
    low = np.nanmin(xy, axis=(0, 1))
    margin = 0.25 * MOCAP_PX_PER_M
    xy = xy - low + margin
    size = np.nanmax(xy, axis=(0, 1)) + margin
    keypoints = np.concatenate([xy, pose3d.confidence[..., None]], axis=-1)
    return Pose2D(keypoints, pose3d.timestamps, COCO17.name, (int(size[0]), int(size[1])))
