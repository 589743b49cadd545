"""Multi-view lifting: calibrated cameras, intrinsic calibration, sync and triangulation.

cameras.py    Camera / CameraGroup (OpenCV model), TOML (Pose2Sim/anipose) and Qualisys I/O
calibrate.py  intrinsics from checkerboard / ChArUco photos
triangulate.py confidence-weighted DLT with bounded camera exclusion
sync.py       camera offsets from audio or keypoint motion; resampling onto one clock
bundle.py     camera poses refined from the person's keypoints (pycolmap bundle adjustment)
lifter.py     the `multiview` lifter (TakeViews: a Pose2D per camera + CameraGroup → Pose3D)

Importing this package does not import mediapipe; the modules import only numpy, scipy, cv2
(and pycolmap, inside `bundle.refine_cameras`).
"""

from gesturebank.config import MultiviewConfig
from gesturebank.lift.multiview.cameras import Camera, CameraGroup

__all__ = ["Camera", "CameraGroup", "MultiviewConfig"]
