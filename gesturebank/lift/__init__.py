"""3D lifters: Pose2D (one view, or several with cameras) → Pose3D in COCO-17 order.

Lifters register by name in `LIFTERS`; plug-ins add theirs through the entry-point group
`gesturebank.lifters` (DESIGN.md "Contracts").
"""

from __future__ import annotations

from typing import Protocol

from gesturebank.poses import Pose2D, Pose3D
from gesturebank.registry import Registry


class Lifter(Protocol):
    name: str

    def lift(self, pose2d: Pose2D) -> Pose3D: ...


LIFTERS: Registry[Lifter] = Registry("lifter", "gesturebank.lifters")

LIFTERS.register_lazy("blazepose-world", "gesturebank.lift.blazepose_world:BlazePoseWorldLifter")
LIFTERS.register_lazy("geometric", "gesturebank.lift.geometric:GeometricLifter")
LIFTERS.register_lazy("fitted", "gesturebank.lift.fitted:FittedLifter")
LIFTERS.register_lazy("multiview", "gesturebank.lift.multiview.lifter:MultiviewLifter")
