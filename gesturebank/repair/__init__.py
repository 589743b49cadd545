"""Repair: the stage that mends the main speaker's keypoints before they are lifted and judged
(docs/architecture.md "Data flow").

Runs per take, at the video's own (possibly variable) timestamps, before clips are cut, so every
function copes with long NaN stretches (the person absent). Three repairs, in this order:

1. **Left/right swaps** (2D only): per body group (arms with the shoulders, legs with the hips,
   face), a two-state Viterbi — labels as given / exchanged — minimises the group's
   frame-to-frame path length (over the pairs seen on both sides in both frames) plus a
   penalty per change of state (the face also pays for sides
   that disagree with the shoulders'); runs of at most `max_swap_s` that disagree with the
   labels before them are exchanged back. Swaps go first because exchanging rows back is
   lossless, while a Hampel filter run on an unrepaired swap takes the swapped samples for
   outliers (a 5-frame swap is 5 of the 13 samples of a 60 fps window) and replaces real,
   only mislabelled, positions by interpolation.
2. **Hampel outliers** in time, per keypoint: the distance to the window's coordinate-wise
   median point against 1.4826·MAD of the window's distances (MAD floored in shoulder widths).
   An outlier is set missing and then interpolated from its neighbours like a gap: linear
   interpolation keeps the local motion of a moving keypoint, where the window median lags
   behind it (and is one-sided at the edges), and an outlier next to a long gap stays missing
   instead of being invented.
3. **Gaps** up to `max_gap_s` are interpolated linearly in time (`filters.fill_gaps`); longer
   ones stay NaN. A filled sample gets the lower confidence of the two samples it is drawn
   between (the one, at an edge): it is no surer than its weaker anchor.

Distances are in shoulder widths (median over the take, in each array's own units), so pixels
and metres, near and far people share the thresholds. Hampel windows are given in seconds and

Three modules: `keypoints` (scale, Hampel outliers and gaps over plain `(T, K, C)` arrays),
`swaps` (the left/right swap repair) and `poses` (the entry points over `Pose2D` / `Pose3D` and
what they report).
"""

from gesturebank.repair.keypoints import (
    fill_keypoint_gaps,
    filled_confidence,
    half_window,
    hampel_outliers,
    shoulder_width,
)
from gesturebank.repair.poses import RepairReport, repair_pose2d, repair_pose3d, validity
from gesturebank.repair.swaps import exchange, swap_frames, swap_groups

__all__ = [
    "RepairReport",
    "exchange",
    "fill_keypoint_gaps",
    "filled_confidence",
    "half_window",
    "hampel_outliers",
    "repair_pose2d",
    "repair_pose3d",
    "shoulder_width",
    "swap_frames",
    "swap_groups",
    "validity",
]
