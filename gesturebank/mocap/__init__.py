"""Motion capture: BVH files read and written, their joint names, BVH -> Pose3D."""

MOCAP = "mocap"  # the "lifter" and "detector" of a motion-capture take: its 3D is measured
