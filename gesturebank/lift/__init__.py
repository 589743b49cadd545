"""3D lifters: a take's 2D view(s) → Pose3D in COCO-17 order.

Every lifter implements `lift(views: TakeViews) -> Pose3D`; a monocular one takes one view, the
multi-view one two or more with their cameras. Lifters register by name in `LIFTERS`; the
registered factory is called with the whole `Config` (`LIFTERS.create(name, config)`, by the
orchestration): the built-ins register their `from_config` classmethod, which hands their own
sections to `__init__` as keyword-only arguments. Plug-ins add theirs through the entry-point
group `gesturebank.lifters` (README "Plug-ins"). What the build must know of a lifter is its
`traits` (`LifterTraits`, `lift.clip_confidence.lifter_traits(name)`), never its name.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from gesturebank.errors import InputError
from gesturebank.poses import Pose2D, Pose3D
from gesturebank.registry import Registry

if TYPE_CHECKING:
    from gesturebank.audio.io import Audio
    from gesturebank.camera_files import Camera, CameraGroup
    from gesturebank.lift.depth_confidence import DepthCalibration


@dataclass(frozen=True, eq=False)
class TakeViews:
    """What a lifter receives: one take seen by one or more cameras.

    poses: one Pose2D per view (in the order of `cameras`); cameras: their calibration, None when
    uncalibrated (a monocular lifter may use a single camera's intrinsics); audios: each view's
    own audio track, for synchronising the views (None: no tracks). It lives beside the protocol,
    not in poses.py: only lifters read it, and it holds cameras and audio, which the pose types
    every stage imports must not depend on.
    """

    poses: tuple[Pose2D, ...]
    cameras: CameraGroup | None = None
    audios: tuple[Audio | None, ...] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "poses", tuple(self.poses))
        if not self.poses:
            raise InputError("TakeViews: no view given")
        if self.audios is not None:
            object.__setattr__(self, "audios", tuple(self.audios))
            if len(self.audios) != len(self.poses):
                raise InputError(
                    f"TakeViews: {len(self.audios)} audio tracks for {len(self.poses)} views"
                )

    @classmethod
    def of(cls, poses: Pose2D | Sequence[Pose2D], cameras: CameraGroup | None = None) -> TakeViews:
        """One Pose2D (a single view) or a sequence of them, with optional cameras."""
        return cls((poses,) if isinstance(poses, Pose2D) else tuple(poses), cameras)

    def single(self, lifter: str) -> Pose2D:
        """The one view of a monocular lifter named `lifter`; InputError for several."""
        if len(self.poses) != 1:
            raise InputError(
                f"lifter {lifter!r} lifts one view, got {len(self.poses)}; the multiview lifter "
                "lifts several"
            )
        return self.poses[0]

    def single_camera(self, lifter: str) -> Camera | None:
        """The one view's camera (None: uncalibrated); InputError for several."""
        if self.cameras is not None and len(self.cameras) != 1:
            raise InputError(
                f"lifter {lifter!r}: one view but {len(self.cameras)} cameras "
                f"({self.cameras.names}); give the view's own camera"
            )
        return None if self.cameras is None else self.cameras[0]


@dataclass(frozen=True)
class LifterTraits:
    """What the orchestration and QC must know of a lifter, declared by the lifter (its class
    attribute `traits`) instead of switched on its name.

    several_views: lifts a multi-camera take (2+ calibrated views) and nothing else;
    measured_depth: its 3D is measured, not inferred (triangulated, motion capture): the depth
    confidence is 1 and its output is not repaired again as a lifter's glitches;
    depth_calibration: its depth confidence measured against truth, giving the expected hand
    error (`lift.depth_confidence`; None: not calibrated, NaN).
    """

    several_views: bool = False
    measured_depth: bool = False
    depth_calibration: DepthCalibration | None = None


class Lifter(Protocol):
    name: str

    def lift(self, views: TakeViews) -> Pose3D: ...


LIFTERS: Registry[Lifter] = Registry("lifter", "gesturebank.lifters")

LIFTERS.register_lazy(
    "blazepose-world", "gesturebank.lift.blazepose_world:BlazePoseWorldLifter.from_config"
)
LIFTERS.register_lazy("geometric", "gesturebank.lift.geometric:GeometricLifter.from_config")
LIFTERS.register_lazy("fitted", "gesturebank.lift.fitted:FittedLifter.from_config")
LIFTERS.register_lazy("resolved", "gesturebank.lift.resolved:ResolvedLifter.from_config")
LIFTERS.register_lazy("learned", "gesturebank.lift.learned:LearnedLifter.from_config")
LIFTERS.register_lazy("multiview", "gesturebank.lift.multiview.lifter:MultiviewLifter.from_config")
