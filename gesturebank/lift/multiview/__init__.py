"""Multi-view lifting: calibrated cameras, intrinsic calibration, sync and triangulation.

(cameras: gesturebank.camera_files, TOML (Pose2Sim/anipose) and Qualisys I/O, beside geometry)
calibrate.py  intrinsics from checkerboard / ChArUco photos
triangulate.py confidence-weighted DLT with bounded camera exclusion
sync.py       camera offsets from audio or keypoint motion; resampling onto one clock
bundle.py     camera poses refined from the person's keypoints (pycolmap bundle adjustment)
lifter.py     the `multiview` lifter (TakeViews: a Pose2D per camera + CameraGroup → Pose3D)

Importing this package does not import mediapipe; the modules import only numpy, scipy, cv2
(and pycolmap, inside `bundle.refine_cameras`).
"""

from gesturebank.camera_files import Camera, CameraGroup
from gesturebank.config import MultiviewConfig

__all__ = ["Camera", "CameraGroup", "MultiviewConfig"]
