"""Options of the repair stage (`[repair]`): the main speaker's keypoints mended before they are
lifted and judged.
"""

from __future__ import annotations

from pydantic import Field

from gesturebank.config.section import Section


class RepairConfig(Section):
    """Repair of the main speaker's keypoints before they are judged (config section `repair`)."""

    hampel_half_window_s: float = Field(
        0.1,
        gt=0,
        description="Half the Hampel filter window, seconds: round(0.1 s × fps) frames each side, "
        "i.e. the 7-frame window of Pose2Sim and Sports2D at 30 fps, scaled with the frame rate.",
    )
    hampel_z: float = Field(
        2.0,
        gt=0,
        description="A keypoint whose modified z-score 0.6745·|x − median| / MAD in its window "
        "exceeds this is an outlier, replaced from its neighbours (Pose2Sim, Sports2D: 2).",
    )
    hampel_floor: float = Field(
        0.02,
        ge=0,
        description="Smallest MAD, in shoulder widths, so that a keypoint held still is not "
        "'repaired' for sub-pixel noise.",
    )
    max_gap_s: float = Field(
        0.25,
        ge=0,
        description="Gaps in a keypoint up to this long (seconds) are interpolated; longer ones "
        "stay missing (masked).",
    )
    swaps: bool = Field(
        True,
        description="Repair left/right swaps of monocular video: runs of frames whose left and "
        "right labels disagree with their neighbours are flipped back.",
    )
    max_swap_s: float = Field(
        1.0, gt=0, description="Longest run of swapped frames that is flipped back, seconds."
    )
    visible_confidence: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Keypoints less confident than this (BlazePose visibility) count as unseen, "
        "as do keypoints outside the image however confident: the angles that need them are "
        "masked (NaN) there.",
    )
    # 0.75 before issue 41, whose bound on a kept one-frame jump is 0.5: kept clips of the real
    # footage held 2D jumps of 0.52 and 0.69 (talking demo, outdoor), 0.71 ("behind"), 0.51
    # ("lowres") shoulder widths; masking the frame keeps the clip (cutting it cost the demo 1.2 s).
    max_spike: float = Field(
        0.5,
        gt=0,
        description="A keypoint that still jumps out and back by more than this in one frame "
        "after repair (in 2D or in the lifted 3D), in shoulder widths, is unseen in that frame "
        "(masked); qc.max_spike judges what is left.",
    )
    # Issue 41 (`repair.snaps`): a joint put on somebody else for a few frames, whatever the
    # detector's confidence (the issue saw a wrist jump 1.41 shoulder widths onto the person
    # behind at confidence 0.98; on Demo_MultiPerson cam04 BlazePose puts the right hand 0.80
    # out, landing 0.26 from the other person's keypoint). The jump it catches is the issue's
    # bound on a kept one-frame jump, 0.5 shoulder widths.
    snap_max_frames: int = Field(
        3,
        ge=0,
        le=10,
        description="Longest run of frames (1 to this) in which a keypoint that leaves its path "
        "and lands on another person's keypoint is a snap, set missing and interpolated "
        "(repair.snaps). 0 = off.",
    )
    snap_near: float = Field(
        0.3,
        gt=0,
        description="A keypoint within this many of the speaker's shoulder widths of another "
        "person's keypoint lies on that person (a snapped joint lands on a joint).",
    )
    snap_min_jump: float = Field(
        0.5,
        gt=0,
        description="How far (shoulder widths) a snapped keypoint leaves the line between the "
        "frames around the run, and further than those are apart (it goes out and back).",
    )
