"""Options of motion-capture takes (`[mocap]`): how their joints are read."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from gesturebank.config.section import Section

MocapUnits = Literal["auto", "m", "cm", "mm", "in"]


class MocapConfig(Section):
    """Motion-capture takes (`<stem>.bvh` with a `<stem>.wav`): how their joints are read."""

    units: MocapUnits = Field(
        "auto",
        description="Unit of the BVH offsets and positions. 'auto' picks m, cm or mm, whichever "
        "makes the skeleton's span (the longest joint-to-joint path, about a person's height) "
        "closest to 1.7 m; set it for inches or for a skeleton that is not person-sized.",
    )
    names: dict[str, str] = Field(
        default_factory=dict,
        description="BVH joint name → point (left_shoulder … right_ankle, head; or nose, "
        "left_eye … right_ear where the skeleton has them), tried before the built-in table of "
        "gesturebank/data/mocap-names.toml, for skeletons it lacks.",
    )
