"""Options of the QC (`[qc]`): the thresholds every clip is judged by."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from gesturebank.config.section import Section

# A clip metric a check can name: the single-number fields of qc's ClipMetrics (config sits below
# qc, so the names are written here too; tests/qc/test_clip_metrics.py keeps the two equal).
MetricName = Literal[
    "duration_s",
    "jerk_raw",
    "jerk",
    "head_unknown_fraction",
    "arms_unknown_fraction",
    "left_arm_unknown_fraction",
    "right_arm_unknown_fraction",
    "torso_gap_s",
    "bone_cv_max",
    "swap_events",
    "frozen_fraction",
    "spike_max",
    "out_of_reach_fraction",
    "frozen_at_limit_s",
    "jitter_fraction",
    "motion_range",
    "facing_away_fraction",
    "sideways_fraction",
    "shoulder_width",
    "image_change",
    "people",
    "speech_fraction",
    "depth_confidence",
    "expected_hand_error_cm",
    "trimmed_fraction",
]


class QCConfig(Section):
    """Thresholds of the QC (config section `qc`), judged per clip. Every one is a share of time,
    seconds, a value on the analysis clock or a size in shoulder widths, so footage at any frame
    rate is judged alike. Defaults were set on the real sample takes (benchmarks/qc.py);
    loosen them for unusual footage rather than editing clips."""

    analysis_rate_hz: float = Field(
        30.0,
        gt=0,
        description="Uniform clock the raw angles are resampled to for jerk and jitter, Hz, so "
        "clips filmed at different frame rates compare (noise jerk grows as rate⁵).",
    )
    jitter_above_hz: float = Field(
        7.0, gt=0, description="Power above this frequency of the raw angles counts as jitter, Hz."
    )
    max_head_unknown_fraction: float | None = Field(
        None,
        ge=0,
        le=1,
        description="Opt-in whole-clip rule (0.5 before issue 32): largest share of the clip in "
        "which the head angles are unknown. None = judged by part: an unseen head is masked "
        "(clips.max_part_unseen_fraction) and the clip keeps its arms.",
    )
    max_arms_unknown_fraction: float | None = Field(
        None,
        ge=0,
        le=1,
        description="Opt-in whole-clip rule (0.5 before issue 32): largest share of the clip in "
        "which both arms are unknown. None = judged by part: unseen arms are masked "
        "(clips.max_part_unseen_fraction) and a head-and-shoulders clip keeps its head.",
    )
    max_bone_cv: float = Field(
        0.25,
        ge=0,
        description="Largest coefficient of variation of a 3D bone length over the frames in "
        "which both its ends were seen (rigid body: 0).",
    )
    max_limit_fraction: float | None = Field(
        None,
        ge=0,
        le=1,
        description="Opt-in filter (the old rule, 0.6 before): largest share of frames with some "
        "joint beyond the robot's reach. None = motion beyond reach is reported "
        "(out_of_reach_fraction, out_of_reach/<Joint>), not judged: the clip keeps its best "
        "reachable version of the motion.",
    )
    max_frozen_at_limit_s: float | None = Field(
        2.0,
        gt=0,
        description="Longest the robot may stand frozen at a limit, seconds: a joint within "
        "frozen_limit_tol of a limit while the person's (unlimited) angle moves more than "
        "frozen_min_motion within frozen_motion_window_s. None = not judged.",
    )
    frozen_limit_tol: float = Field(
        0.02, gt=0, description="A joint this close to a limit (rad) counts as held there."
    )
    frozen_min_motion: float = Field(
        0.2,
        ge=0,
        description="Range of the person's angle (rad) within qc.frozen_motion_window_s, while "
        "the robot is held at a limit, above which the robot is frozen while the person moves.",
    )
    # Issue 41: the range was taken over the whole held run, so a limb folded past the limit and
    # then kept still counted as moving: test.bvh 225-237 s folds the right elbow to 118-131°
    # (Pepper stops at 89.5°) and holds it, a 12 s run whose range (0.41 rad) came from the fold
    # itself; the robot holding its limit there is the right retarget, and the rule cut 8.4 s.
    # Moving within a 0.5 / 1 / 2 s window lasts 0.25 / 0.78 / 2.46 s of that run: a 2 s window
    # counts the fold and its settling as 2.5 s of motion; 1 s counts the fold alone. No other
    # held run of test.bvh moves 0.2 rad within any 2 s (benchmarks/kept_error.py --mocap).
    frozen_motion_window_s: float = Field(
        1.0,
        gt=0,
        description="Window (s) over which the person's angle must span more than "
        "frozen_min_motion for a sample held at a limit to count as frozen while the person "
        "moves; a limb held still past the limit is not frozen.",
    )
    max_speed_factor: float = Field(
        1.5,
        gt=0,
        le=1.5,
        description="Invariant: no processed angle steps between two samples more than this × "
        "the robot profile's joint speed allows (a jump, e.g. across the joint's range).",
    )
    max_jitter_fraction: float = Field(
        0.15, ge=0, le=1, description="Largest share of raw-angle power above jitter_above_hz."
    )
    max_swap_events: int = Field(
        0,
        ge=0,
        description="Left/right exchanges of the arms left after repair tolerated in a clip.",
    )
    # 0.75 before issue 41, when a jump cost its whole clip; now it costs its frames and 0.2 s
    # either side (a stretch check), and kept clips of the real footage held jumps of 0.71
    # ("behind") and 0.51 ("lowres") shoulder widths, glitches nobody makes.
    max_spike: float = Field(
        0.5,
        gt=0,
        description="Largest one-frame jump of a seen keypoint out and back, in shoulder widths "
        "(in the 2D and in the 3D); a larger one is cut out with qc.stretch_margin_s either side.",
    )
    max_frozen_fraction: float = Field(
        0.1, ge=0, le=1, description="Largest share of frames where the pose is exactly repeated."
    )
    min_motion_range: float = Field(
        0.035,
        ge=0,
        description="A clip whose every joint moves less than this (5–95 % range, rad; "
        "0.035 rad = 2°) is static.",
    )
    # The view limits follow the measured error (benchmarks/depth_confidence.py --set tune
    # --views: BlazePose + blazepose-world on renders of test.bvh outside 31–51 s, 2700 frames).
    # Per frame, by what QC's rules call it: seen from the front (neither rule) 10.1 cm Pepper
    # hand error, 17.2° arm-angle error, 8 % wrong depth signs; from the side 13.2 cm, 25.5°,
    # 28 %; facing away 11.9 cm, 23.3°, 20 % (by the true view, the costly frames are those
    # turned 45–135°; a back view, 135–180°, costs little more than the front). Bound: a clip's
    # mean hand and arm-angle error at most 25 % above its front frames'. A share f of frames
    # seen so costs front + f·(seen − front), so f ≤ 0.25·front / (seen − front): sideways
    # min(0.81 by hand, 0.52 by arm) → 0.5 (the old limit holds), facing away min(1.4, 0.70) →
    # 0.7 (was 0.3, youtube-gesture-dataset's). Checked on test.bvh 31–51 s (--set acceptance):
    # front 9.1 cm / 17.7°, sideways 8.3 / 23.4°, facing away 8.7 / 20.0° — inside the bound.
    # Measured again for issue 41 with the learned lifter (the default since), same frames:
    # neither 3.8 cm / 6.5°, sideways 5.8 / 9.9°, facing away 4.6 / 9.1°; sideways min(0.48 by
    # hand, 0.48 by arm) keeps 0.5, and the frames it calls so are the costly ones (nose along
    # the shoulder line 0.4–0.5: 4.0 cm / 6.0°; 0.5–0.7: 5.6–9.3 cm / 9.1–17.8°), so a 60°
    # camera is not judged too strictly. Facing away by arm: 0.63, under its 0.7.
    max_facing_away_fraction: float = Field(
        0.7,
        ge=0,
        le=1,
        description="Largest share of frames in which the speaker faces away (their right "
        "shoulder right of their left in the image): up to it a clip's mean hand and arm-angle "
        "error stay within 25 % of its front frames' on the project's renders (was 0.3, "
        "youtube-gesture-dataset's).",
    )
    max_sideways_fraction: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Largest share of frames in which the speaker is seen from the side (nose "
        "outside the shoulders): up to it a clip's mean arm-angle error stays within 25 % of its "
        "front frames' on the project's renders (youtube-gesture-dataset's 50 %, measured).",
    )
    min_shoulder_width: float = Field(
        0.03,
        ge=0,
        description="Smallest median shoulder width, as a share of the frame height: smaller "
        "speakers are too far for a reliable pose (youtube-gesture-dataset: 100 px of 720).",
    )
    min_image_change: float = Field(
        0.05,
        ge=0,
        description="Smallest median change between frames (the shot detector's HSV content "
        "value): below it the video is a still picture.",
    )
    max_people: float = Field(
        5.0,
        gt=0,
        description="Most people in the frame on average (youtube-gesture-dataset: 5).",
    )
    min_speech_fraction: float | None = Field(
        0.25,
        ge=0,
        le=1,
        description="Smallest share of a clip with speech heard (Silero VAD, `[speech]`): "
        "below it the clip is rejected as 'no speech'. The talking demo's clips hold 80-83 % "
        "speech, a take with silent audio 0 %. None = not judged.",
    )
    # On the tuning renders the calibrated expectation tracked the measured error per 5 s window
    # (correlation 0.79); the windows above 12.5 cm (mean confidence ≤ 0.15: an arm bone along
    # the camera's ray most of the time) measured 14.7 and 17.3 cm against 10.8 cm overall.
    max_expected_hand_error_cm: float | None = Field(
        12.5,
        gt=0,
        description="Largest Pepper hand error (cm) a clip's depth confidence predicts "
        "(`expected_hand_error_cm`, calibrated on the project's renders per lifter): above it "
        "the clip is rejected as 'depth uncertain'. None = reported, not judged.",
    )
    max_trimmed_fraction: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Largest share of a take's video that trimming audio and video to their "
        "common span may drop (a .wav much shorter than its video is often the wrong file); "
        "above it the build warns and the take's clips are rejected.",
    )
    max_jerk_raw: float | None = Field(
        None,
        gt=0,
        description="Absolute ceiling on the raw jerk J (Eq. 3.21, rad² s⁻⁵); none = only the "
        "dataset-relative check.",
    )
    # Issue 41: a check of scope "stretch" (qc.table) cuts the clip around the stretch that
    # fails it. The margin covers the frames either side of a glitch that the filters smear it
    # into (the 100 Hz low-pass's step response settles within ~0.15 s at 4 Hz); more only
    # costs footage.
    stretch_margin_s: float = Field(
        0.2,
        ge=0,
        description="Seconds dropped either side of a stretch cut out by a stretch check "
        "(frozen at a limit, sideways, facing away, depth uncertain, jitter, glitches, no "
        "speech); the pieces left become clips again when they last clips.min_s.",
    )
    stretch_rounds: int = Field(
        3,
        ge=0,
        description="How often a piece that fails again is cut again before it is rejected "
        "whole. 0 = the old rule: a clip failing any check is rejected whole.",
    )
    outlier_metrics: list[MetricName] = Field(
        ["jerk_raw", "jerk"],
        description="Metrics checked for dataset-relative outliers (robust z of their log).",
    )
    outlier_z: float = Field(3.5, gt=0, description="Robust z-score above which a clip stands out.")
    outlier_min_ratio: float = Field(
        3.0, ge=1, description="…and its metric must also exceed this × the dataset median."
    )
    outlier_min_clips: int = Field(
        5, ge=3, description="Fewer clips than this: no dataset-relative check."
    )
