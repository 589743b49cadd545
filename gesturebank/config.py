"""Configuration: one validated pydantic model per stage, loaded from TOML, overridden on the CLI.

Precedence is defaults < file < command-line flags. The fully resolved config is what gets saved
with every output (and hashed, so a re-run knows whether a built take is still valid). Every
field says its unit and when to change it; `gesturebank.toml` is the commented example of the
same, shipped in the package as gesturebank/data/gesturebank.toml (`commented_example`,
`gesturebank config --commented`; the repository's top-level file is that one, linked).
"""

from __future__ import annotations

import difflib
import hashlib
import json
import os
import re
import tomllib
from collections.abc import Iterable, Mapping
from importlib import resources
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator
from pydantic_core import PydanticCustomError

from gesturebank.errors import ConfigError
from gesturebank.registry import plugin_section


class Section(BaseModel):
    """A config section: unknown keys are errors, values are validated on assignment too."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=False)


class VideoConfig(Section):
    stride: int = Field(1, ge=1, description="Use every Nth decoded frame (1 = all frames).")
    start_s: float = Field(0.0, ge=0, description="Start of the used time range, seconds.")
    end_s: float | None = Field(
        None, gt=0, description="End of the used time range, seconds (none = end of video)."
    )
    max_fps: float | None = Field(
        30.0,
        gt=0,
        description="Footage above this frame rate is detected on a regular subset of its "
        "frames (a frame is kept when at least 0.75 / max_fps s passed since the last kept one); "
        "timestamps stay the real ones. The 4 Hz low-pass keeps nothing above 15 Hz; none = "
        "every frame.",
    )

    @model_validator(mode="after")
    def _range(self) -> VideoConfig:
        if self.end_s is not None and self.end_s <= self.start_s:
            raise ValueError("end_s must be greater than start_s")
        return self


class DetectorConfig(Section):
    name: str = Field(
        "blazepose",
        description="2D detector: 'blazepose' (multi-person BlazePose on the TFLite runtime), "
        "'mediapipe' (mediapipe's single-person solution, the reference), 'openpose-json' or a "
        "plug-in name.",
    )
    model_complexity: int = Field(
        1,
        ge=0,
        le=2,
        description="BlazePose model: only 1 (Full) is bundled with mediapipe 0.10.14; "
        "0 and 2 would need a download.",
    )
    min_detection_confidence: float = Field(
        0.5, ge=0, le=1, description="Person detector threshold; lower it for small or far people."
    )
    min_tracking_confidence: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Pose presence below which a person's track is lost and the detector runs "
        "again.",
    )
    max_people: int = Field(
        4,
        ge=1,
        le=8,
        description="Most people followed per frame ('blazepose'; the 'mediapipe' reference "
        "follows one). Each costs one landmark pass per frame.",
    )
    detect_every_s: float = Field(
        0.5,
        gt=0,
        description="'blazepose': the person detector runs at least this often (seconds) to find "
        "people who come in; at once when a track is lost or fewer than max_people are tracked "
        "only at this interval.",
    )
    small_people: bool = Field(
        False,
        description="'blazepose': also look for small people (down to ~1/4 of the frame height, "
        "e.g. a far bystander) in overlapping squares of half the frame's short side, each time "
        "the person detector runs (frames whose short side is at least 448 px). On a 1088x1920 "
        "frame that is 15 more detector passes per run (each ~0.7 of a landmark pass), and each "
        "small person found costs a landmark pass per frame.",
    )
    smoothing: bool = Field(
        True, description="One-euro smoothing of the landmarks on the video's own timestamps."
    )
    smoothing_min_cutoff: float = Field(
        0.05, gt=0, description="One-euro minimum cut-off of image landmarks, Hz (mediapipe: 0.05)."
    )
    smoothing_beta: float = Field(
        80.0, ge=0, description="One-euro speed coefficient of image landmarks (mediapipe: 80)."
    )
    world_smoothing_min_cutoff: float = Field(
        0.1, gt=0, description="One-euro minimum cut-off of world landmarks, Hz (mediapipe: 0.1)."
    )
    world_smoothing_beta: float = Field(
        40.0, ge=0, description="One-euro speed coefficient of world landmarks (mediapipe: 40)."
    )
    json_suffix: str = Field(
        "_json",
        description="Folder '<video stem><suffix>' next to a video holds precomputed "
        "OpenPose-format JSON keypoints.",
    )


class ShotsConfig(Section):
    """Shot boundaries (scene cuts) found in the decoded frames (config section `shots`)."""

    detector: Literal["content", "none"] = Field(
        "content",
        description="'content': PySceneDetect's ContentDetector on the frames the detector sees; "
        "'none': a take is one shot (footage known to be uncut).",
    )
    threshold: float = Field(
        27.0,
        gt=0,
        description="ContentDetector threshold on the HSV change between frames (0–255; "
        "PySceneDetect's default 27). Lower it to find softer cuts, raise it against false cuts "
        "on fast camera motion.",
    )
    min_shot_s: float = Field(
        0.5,
        ge=0,
        description="Shortest shot, seconds: a cut closer than this to the last is ignored.",
    )


class TrackingConfig(Section):
    size_weight: float = Field(
        1.0, ge=0, description="Weight of upper-body size in speaker choice."
    )
    center_weight: float = Field(1.0, ge=0, description="Weight of closeness to image centre.")
    confidence_weight: float = Field(1.0, ge=0, description="Weight of mean keypoint confidence.")
    persistence_weight: float = Field(
        1.0, ge=0, description="Weight of the share of the shot in which the person is seen."
    )
    speech_weight: float = Field(
        1.0,
        ge=0,
        description="Weight of how well the person's head and hand motion follows the speech "
        "envelope of the take's audio (0 = ignore the audio).",
    )
    speech_window_s: float = Field(
        4.0,
        gt=0,
        description="Sliding window of the motion–speech cross-correlation, seconds.",
    )
    gate: float = Field(
        0.25,
        gt=0,
        description="Largest match distance between frames, as a fraction of the image "
        "diagonal; beyond it a detection starts a new identity.",
    )
    max_lost_s: float = Field(
        2.0, gt=0, description="A track unseen for longer than this (seconds) ends."
    )
    predict_s: float = Field(
        0.2,
        ge=0,
        description="Over gaps up to this long (s) a track's pose is moved on by its velocity.",
    )
    switch_window_s: float = Field(
        0.5,
        gt=0,
        description="A track appearing within this many seconds of another vanishing is "
        "reported as an identity switch.",
    )


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
        description="Keypoints less confident than this (BlazePose visibility) count as unseen: "
        "the angles that need them are masked (NaN) there.",
    )
    max_spike: float = Field(
        0.75,
        gt=0,
        description="A keypoint that still jumps out and back by more than this in one frame "
        "after repair (in 2D or in the lifted 3D), in shoulder widths, is unseen in that frame "
        "(masked); qc.max_spike judges what is left.",
    )


class ClipsConfig(Section):
    """How a take is cut into clips, the unit of the dataset (config section `clips`)."""

    min_s: float = Field(
        3.0,
        gt=0,
        description="Shorter clips are dropped (with their reason), seconds. 3 s = the LSTM's "
        "training window and youtube-gesture-dataset's rule.",
    )
    max_s: float | None = Field(
        None, gt=0, description="Longer clips are split into equal parts, seconds (none = never)."
    )
    max_gap_s: float = Field(
        0.5,
        ge=0,
        description="A clip ends where the main speaker is absent (or no usable pose is left "
        "after repair) for longer than this, seconds; shorter gaps stay inside, masked.",
    )

    @model_validator(mode="after")
    def _lengths(self) -> ClipsConfig:
        if self.max_s is not None and self.max_s < self.min_s:
            raise ValueError("max_s must be at least min_s")
        return self


class LifterConfig(Section):
    name: str = Field(
        "blazepose-world",
        description="3D lifter of single-view takes: 'blazepose-world' (learned), 'fitted' (a "
        "skeleton fitted to the 2D with BlazePose's 3D as prior), 'resolved' (each arm bone's "
        "depth sign decoded over the take; best from true 2D, not yet at 60° from BlazePose's), "
        "'geometric' (assumptions) or a plug-in name; multi-camera takes always use 'multiview'.",
    )


class GeometricConfig(Section):
    """Options of the `geometric` lifter; every assumption of the module docstring has a switch."""

    robust_lengths: bool = Field(
        True,
        description="A2: bone lengths = a percentile of the 2D lengths over the whole take; "
        "false = the dissertation's causal running maximum.",
    )
    length_percentile: float = Field(
        95.0,
        gt=0,
        le=100,
        description="Percentile of the 2D lengths taken as a bone's true length; lower it when "
        "the detector often over-stretches bones, raise it when bones rarely lie in the image.",
    )
    torso_facing_camera: bool = Field(
        True,
        description="A3: shoulders and hips lie in a plane parallel to the image (z = 0); "
        "false = estimate the torso's yaw from its width foreshortening.",
    )
    head_in_front: bool = Field(
        True, description="A4: nose, eyes and ears are in front of the torso plane."
    )
    arms_in_front: bool = Field(
        True, description="A4: elbows (and wrists) are in front of the torso plane."
    )
    wrist_beyond_elbow: bool = Field(
        True, description="A5: each wrist is further in front of the torso plane than its elbow."
    )
    min_confidence: float = Field(
        0.05, ge=0, le=1, description="Keypoints below this confidence are treated as missing."
    )
    visible_confidence: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Keypoints at or above this confidence count as seen: only they estimate "
        "bone lengths, and an arm keypoint inside the torso outline below it is flagged behind.",
    )
    length_tolerance: float = Field(
        0.1,
        ge=0,
        description="A bone longer in 2D than (1 + this) × its estimated length is flagged "
        "too_long (fraction; measurement noise stays below it).",
    )
    ambiguity_tolerance: float = Field(
        0.1,
        ge=0,
        le=1,
        description="With a sign prior off, a depth up to this fraction of the bone length "
        "is not ambiguous (both signs give nearly the same point).",
    )
    flag_confidence: float = Field(
        0.25, ge=0, le=1, description="Confidence of a flagged joint is multiplied by this."
    )
    units: Literal["relative", "m"] = Field(
        "relative",
        description="'relative' = pixels / image height; 'm' = scaled by an assumed shoulder "
        "width (shoulder_width_m).",
    )
    shoulder_width_m: float = Field(
        0.35,
        gt=0,
        description="Assumed distance between the shoulder joints, metres (units = 'm' only).",
    )


class FittedConfig(Section):
    """Options of the `fitted` lifter: a constant-length skeleton fitted to the 2D per frame."""

    fov_deg: float = Field(
        60.0,
        gt=1,
        lt=179,
        description="Field of view across the longer image side, degrees, when no calibration "
        "gives the focal length; typical of phones and webcams (wide-angle lenses: raise it).",
    )
    min_confidence: float = Field(
        0.3, ge=0, le=1, description="Keypoints below this confidence do not pull the fit."
    )
    prior_weight: float = Field(
        40.0,
        ge=0,
        description="Pixels of reprojection error worth a unit difference between a fitted bone "
        "direction and the prior's (BlazePose world landmarks, else the geometric lifter); "
        "raise it when the detector's 2D is noisy, lower it to trust the image more.",
    )
    smoothness: float = Field(
        0.05,
        ge=0,
        description="Pixels of reprojection error worth 1 m/s² of bone acceleration (temporal "
        "smoothness); 0 fits every frame on its own.",
    )
    length_weight: float | None = Field(
        5.0,
        gt=0,
        description="Pixels of reprojection error worth a 100 % change of a bone length from "
        "the prior's, when the take's lengths are fitted to the image; none keeps the prior's "
        "lengths.",
    )
    flag_angle_deg: float = Field(
        30.0,
        gt=0,
        description="A bone whose fitted direction differs from the prior's by more than this "
        "flags its joint (degrees).",
    )
    flag_confidence: float = Field(
        0.25, ge=0, le=1, description="Confidence of a flagged joint is multiplied by this."
    )
    chunk_frames: int = Field(
        300,
        ge=10,
        description="Frames fitted in one least-squares problem (long takes are cut into "
        "overlapping chunks, so memory stays bounded).",
    )


class ResolvedConfig(Section):
    """Options of the `resolved` lifter: each bone's depth sign decoded over the take."""

    speed_m_s: float = Field(
        1.5,
        gt=0,
        description="Typical joint speed (m/s): moving a joint this far in a second costs as "
        "much as one unit of the anatomical costs, so a sign flip where the two readings lie "
        "far apart costs a lot.",
    )
    accel_m_s2: float = Field(
        20.0,
        gt=0,
        description="Typical joint acceleration (m/s²): a bone bouncing back off the image "
        "plane instead of swinging through it costs its change of depth velocity in these units.",
    )
    face_weight: float = Field(
        20.0, ge=0, description="Cost of the nose not in front of the torso (per unit)."
    )
    face_ahead: float = Field(
        0.1,
        description="How far in front of the neck the nose must be, along the torso's forward, "
        "in neck → nose lengths, before it costs nothing.",
    )
    anatomy_weight: float = Field(
        20.0,
        ge=0,
        description="Cost per unit of the anatomical limits: an elbow folded past "
        "max_elbow_bend_deg, an upper arm reaching behind past max_behind (cosines), an elbow "
        "or hand inside the torso (per 10 cm).",
    )
    max_elbow_bend_deg: float = Field(
        150.0, gt=0, le=180, description="The elbow bends no further than this, degrees."
    )
    max_behind: float = Field(
        0.6,
        ge=-1,
        le=1,
        description="The upper arm's unit vector points backwards (behind the torso's plane) "
        "by at most this much.",
    )
    front_weight: float = Field(
        1.0,
        ge=0,
        description="Small cost of the hand behind the shoulder's plane (per arm length): "
        "gesturing hands are mostly in front.",
    )
    detector_weight: float = Field(
        4.0,
        ge=0,
        description="Cost of a bone pointing away from the detector's own 3D (BlazePose world "
        "landmarks), per squared unit-vector difference; 0 ignores them.",
    )
    depth_levels: int = Field(
        21,
        ge=2,
        description="Readings of the shoulder line per frame: 2 = its exact near and far points "
        "for the estimated shoulder width; more = that many depths along the ray, each costing "
        "its width's deviation (length_sd), so a small width error cannot turn a torso that "
        "faces the camera (on test.bvh: torso frame 10° off with 2, 1° with 21). Cost grows with "
        "the cube. The arms always use the exact pair (the levels were worse there).",
    )
    length_sd: float = Field(
        0.04,
        gt=0,
        description="Relative deviation of a bone from its estimated length worth one unit of "
        "cost (depth_levels > 2).",
    )
    length_percentile: float = Field(
        95.0,
        gt=50,
        le=100,
        description="Each bone's length: this percentile of its 2D length over the take, "
        "scaled to metres at the neck's depth.",
    )
    depth_window_s: float = Field(
        1.0,
        gt=0,
        description="Running median (seconds) of the spine's 2D length that gives the neck's "
        "depth.",
    )


class MultiviewConfig(Section):
    """Triangulation thresholds and camera synchronisation of the `multiview` lifter."""

    min_confidence: float = Field(
        0.3,
        ge=0,
        le=1,
        description="2D keypoints below this detector confidence are ignored (Pose2Sim: 0.3).",
    )
    max_error_px: float = Field(
        12.0,
        gt=0,
        description="Mean reprojection error (pixels) above which the worst cameras are "
        "excluded. 12 px suits BlazePose on 1080p video; raise it for larger images or looser "
        "detectors (Pose2Sim uses 15).",
    )
    reject_error_px: float | None = Field(
        50.0,
        gt=0,
        description="Joints still above this error (pixels) after exclusion become NaN; "
        "none keeps everything that was triangulated.",
    )
    min_cameras: int = Field(2, ge=2, description="Fewest cameras a joint is triangulated from.")
    max_combinations: int = Field(
        64,
        ge=1,
        description="Most camera subsets tried per joint before the search turns greedy "
        "(dropping the worst camera); bounds the cost with many cameras.",
    )
    sync: Literal["none", "audio", "motion", "auto"] = Field(
        "none",
        description="Time offsets between cameras: 'none' (hardware-synchronised), 'audio' "
        "(cross-correlate audio tracks), 'motion' (cross-correlate keypoint speed), 'auto' "
        "(audio where every camera has it, else motion).",
    )
    offsets_s: list[float] | None = Field(
        None,
        description="Known offsets, seconds, one per camera (camera clock minus reference "
        "clock); overrides `sync`.",
    )
    max_offset_s: float = Field(
        2.0, gt=0, description="Largest offset the synchronisation searches for, seconds."
    )
    reference_camera: int = Field(
        0, ge=0, description="Index of the camera whose clock and frames the 3D pose follows."
    )
    max_bone_dev: float = Field(
        0.2,
        gt=0,
        description="A joint whose bone to its parent is off the take's median length by more "
        "than this share is solved again from other cameras and labels (a mislabelled or "
        "swapped 2D point), else dropped.",
    )
    max_jump: float = Field(
        0.5,
        gt=0,
        description="Same for a joint this far (shoulder widths) from the running median of "
        "its own track over 7 frames.",
    )
    back_view_cos: float | None = Field(
        -0.3,
        ge=-1,
        le=1,
        description="A camera sees the person's back where the cosine between the torso's "
        "forward direction and the direction to the camera is below this (-0.3: over 107° off "
        "the chest); its nose and eyes (the detector's guesses there) are then ignored wherever "
        "enough cameras facing the person saw them. None keeps every face keypoint.",
    )
    refine: bool = Field(
        False,
        description="After the robust DLT, fit the whole take at once (soft-L1 reprojection, "
        "smooth acceleration, one length per bone); false keeps the per-point DLT. Off by "
        "default: on the Pose2Sim demo (4 cameras, 100 frames) it evens bones (largest bone "
        "CV 0.17 -> 0.09) but raises the median reprojection error (8.0 -> 8.9 px) and does not "
        "bring disjoint camera pairs closer (16-27 deg mean apart, unrefined 16-26).",
    )
    smooth_accel_mps2: float = Field(
        30.0,
        gt=0,
        description="Refinement: acceleration (m/s²) that costs as much as 3 px of "
        "reprojection error; lower smooths more.",
    )
    bone_tolerance_m: float = Field(
        0.01,
        gt=0,
        description="Refinement: bone-length deviation (m) that costs as much as 3 px of "
        "reprojection error; lower holds bones more rigid.",
    )
    refine_chunk_frames: int = Field(
        300, ge=30, description="Refinement: frames fitted together (long takes in chunks)."
    )

    @model_validator(mode="after")
    def _reject(self) -> MultiviewConfig:
        if self.reject_error_px is not None and self.reject_error_px < self.max_error_px:
            raise ValueError("reject_error_px must be at least max_error_px")
        return self


class BoardConfig(Section):
    """The printed board `gesturebank calibrate` finds in the photos (lift.multiview.calibrate)."""

    kind: Literal["checkerboard", "charuco"] = Field(
        "checkerboard", description="'checkerboard' (plain squares) or 'charuco' (with markers)."
    )
    inner_corners: tuple[int, int] = Field(
        (4, 7),
        description="Checkerboard only: inner corners along x and y (squares − 1 each way). "
        "Pose2Sim's demo board is 4 x 7.",
    )
    squares: tuple[int, int] = Field(
        (7, 5), description="ChArUco only: number of squares along x and y."
    )
    square_size: float = Field(
        0.06, gt=0, description="Side of one square, metres (sets the unit of extrinsics)."
    )
    marker_size: float = Field(
        0.045, gt=0, description="ChArUco only: side of one ArUco marker, metres."
    )
    dictionary: str = Field(
        "DICT_4X4_50", description="ChArUco only: ArUco dictionary name from cv2.aruco."
    )
    legacy_pattern: bool = Field(
        False, description="ChArUco only: boards made with OpenCV < 4.6 (even row count)."
    )
    min_corners: int = Field(
        6, ge=4, description="ChArUco only: fewest corners for a photo to count as a view."
    )

    @model_validator(mode="after")
    def _sizes(self) -> BoardConfig:
        if min(self.inner_corners) < 2 or min(self.squares) < 2:
            raise ValueError("a board needs at least 2 corners/squares in each direction")
        if self.kind == "charuco":
            import cv2  # only a ChArUco board needs it: loading a config stays light

            if self.marker_size >= self.square_size:
                raise ValueError("marker_size must be smaller than square_size")
            if not hasattr(cv2.aruco, self.dictionary):
                raise ValueError(f"unknown ArUco dictionary {self.dictionary!r}")
        return self

    def describe(self) -> str:
        if self.kind == "checkerboard":
            x, y = self.inner_corners
            return f"{x}x{y} inner-corner checkerboard"
        x, y = self.squares
        return f"{x}x{y}-square ChArUco board ({self.dictionary})"


class RobotConfig(Section):
    profile: str = Field(
        "pepper-1.7",
        description="Robot profile for joint limits: 'pepper-1.7' (dissertation Table 3.1) or "
        "'pepper-1.8' (public Pepper URDF).",
    )


class RetargetConfig(Section):
    kinematics: Literal["urdf", "ideal"] = Field(
        "urdf",
        description="Arm chain the retargeting inverts: 'urdf' (Pepper's own, with the 15 mm "
        "elbow offset and the pitched elbow frame: the robot's hand follows the person's) or "
        "'ideal' (offset-free pitch-roll-yaw-roll chain).",
    )
    reach: Literal["clamp", "soft"] = Field(
        "soft",
        description="Motion beyond the robot's reach, mapped once where the dataset's angles "
        "are made: 'clamp' holds a joint at its limit while the person is beyond it; 'soft' "
        "compresses the last soft_margin rad before each limit with a tanh, so the robot keeps "
        "moving with the person's timing. Soft is the default because it more than halves the "
        "time held at a limit for at most +1 cm of hand error (benchmarks/retarget.py, frames "
        "with a joint within 0.02 rad of a limit, clamp → soft 0.65 rad: test.bvh's first 30 s "
        "91 → 36 %, the 4-camera demo 68 → 18 %, the talking demo 25 → 5 %; mean hand error "
        "against the unlimited pose +0.54, +0.78, +0.42 cm).",
    )
    soft_margin: float = Field(
        0.65,
        gt=0,
        description="Width of the soft reach margin before each limit, rad (at most a quarter "
        "of a joint's range is used). 0.65: with 0.5 the robot's RElbowYaw stood within 0.02 rad "
        "of its limit for 2.6 s of test.bvh's first 30 s while the person's moved (rejected as "
        "frozen), with 0.6 its LElbowYaw for 2.3 s on the builder's clock; with 0.75 the "
        "4-camera demo's hand error grew by 1.03 cm.",
    )


class ProcessingConfig(Section):
    rate_hz: float = Field(
        100.0, gt=0, description="Frame clock of angles and audio features, Hz (10 ms hop)."
    )
    butter_order: int = Field(5, ge=1, le=10, description="Butterworth low-pass order (§4.2.3).")
    cutoff_hz: float = Field(
        4.0, gt=0, description="Butterworth cut-off, Hz; the dissertation chose 4 Hz (§4.2.3)."
    )
    max_gap_s: float = Field(
        0.25, ge=0, description="Gaps in the pose up to this long are interpolated, seconds."
    )
    max_speed: float = Field(
        1.0,
        gt=0,
        le=1.5,
        description="The processed angles step at most this × the robot profile's joint speed "
        "between two samples (rate-limited forwards and backwards, averaged: no lag). A lifter's "
        "depth flip or a face detected backwards for a few frames otherwise becomes a sweep "
        "faster than the robot can move (measured up to 5.2× on the demo's outdoor take).",
    )

    @model_validator(mode="after")
    def _nyquist(self) -> ProcessingConfig:
        if self.cutoff_hz >= self.rate_hz / 2:
            raise ValueError("cutoff_hz must be below rate_hz / 2 (Nyquist)")
        return self


FeatureKind = Literal["logfb26", "logfb52", "logfb78", "mfcc13"]


class AudioConfig(Section):
    sample_rate: int = Field(16000, ge=8000, description="Audio is resampled to this rate, Hz.")
    features: FeatureKind = Field(
        "logfb26",
        description="LogFB-26 (default), with deltas (52) and delta-deltas (78), or MFCC-13.",
    )
    preemph: float = Field(0.97, ge=0, lt=1, description="Pre-emphasis coefficient.")
    winlen_s: float = Field(0.025, gt=0, description="Analysis window length, seconds.")
    winstep_s: float = Field(0.01, gt=0, description="Hop between frames, seconds (= 100 Hz).")
    window: Literal["none", "hamming"] = Field(
        "none",
        description="Window function on each frame: 'none' (rectangular) is the default of "
        "python_speech_features' logfbank and mfcc, the dissertation's features; 'hamming' is "
        "Eq. 3.2.",
    )
    nfft: int = Field(512, ge=64, description="FFT size; must cover winlen_s × sample_rate.")
    nfilt: int = Field(26, ge=1, le=128, description="Number of Mel filters.")
    delta_n: int = Field(2, ge=1, description="Half-width of the delta regression window.")

    @model_validator(mode="after")
    def _nfft(self) -> AudioConfig:
        if self.nfft < round(self.winlen_s * self.sample_rate):
            raise ValueError("nfft must be at least winlen_s × sample_rate samples")
        return self


class SpeechConfig(Section):
    """Speech activity (Silero VAD) and who speaks (mouth opening against the speech envelope)."""

    threshold: float = Field(
        0.5,
        gt=0,
        lt=1,
        description="Speech starts where the VAD's speech probability reaches this.",
    )
    release_threshold: float = Field(
        0.35,
        gt=0,
        lt=1,
        description="Speech ends only where the probability falls below this (hysteresis: no "
        "flicker on a probability hovering near `threshold`).",
    )
    max_silence_s: float = Field(
        2.0,
        gt=0,
        description="Silences longer than this cut a clip; shorter ones are marked in `speech`.",
    )
    min_face_px: float = Field(
        48.0,
        gt=0,
        description="Faces narrower than this (pixels, estimated from the eyes) get no mouth "
        "measurement.",
    )
    max_face_turn: float = Field(
        1.0,
        gt=0,
        description="A face counts as facing the camera when its nose lies within this many half "
        "eye distances of the eyes' midpoint, along the eye line (about tan(yaw): 1 = 45°).",
    )
    min_face_confidence: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Face keypoints (nose, eyes) below this confidence count as unseen.",
    )
    speaking_window_s: float = Field(
        1.5,
        gt=0,
        description="Sliding window over which mouth-opening speed is correlated with the speech "
        "envelope, seconds.",
    )
    still_mouth_range: float = Field(
        0.03,
        ge=0,
        description="A mouth whose opening (share of the face's height) spans less than this "
        "within a window (10th to 90th percentile) is still there: speaking score 0. Closed "
        "mouths measured 0.0015-0.015 (Pose2Sim Demo_MultiPerson cam04).",
    )
    speaking_max_lag_s: float = Field(
        0.25,
        ge=0,
        description="Largest delay of the mouth behind the speech envelope searched, seconds.",
    )

    @model_validator(mode="after")
    def _hysteresis(self) -> SpeechConfig:
        if self.release_threshold > self.threshold:
            raise ValueError("release_threshold must not exceed threshold")
        return self


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
    max_head_unknown_fraction: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Largest share of the clip in which the head angles are unknown (face unseen).",
    )
    max_arms_unknown_fraction: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Largest share of the clip in which both arms are unknown (one unseen arm "
        "is only masked).",
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
        "frozen_min_motion. None = not judged.",
    )
    frozen_limit_tol: float = Field(
        0.02, gt=0, description="A joint this close to a limit (rad) counts as held there."
    )
    frozen_min_motion: float = Field(
        0.2,
        ge=0,
        description="Range of the person's angle (rad) over a span held at a limit above which "
        "the robot is frozen while the person moves.",
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
    max_spike: float = Field(
        0.75,
        gt=0,
        description="Largest one-frame jump of a seen keypoint out and back, in shoulder widths.",
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
    max_facing_away_fraction: float = Field(
        0.3,
        ge=0,
        le=1,
        description="Largest share of frames in which the speaker faces away (their right "
        "shoulder right of their left in the image; youtube-gesture-dataset: 30 %).",
    )
    max_sideways_fraction: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Largest share of frames in which the speaker is seen from the side (nose "
        "outside the shoulders; youtube-gesture-dataset: 50 %).",
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
    outlier_metrics: list[str] = Field(
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


Variant = Literal["si", "sd"]


class EvalConfig(Section):
    """The field's measures in `evaluate` and `compare` (GENEA 2022, BEAT; section
    `[train.eval]`): histograms, the FGD feature autoencoder, beat consistency."""

    accel_bin: float = Field(
        0.5, gt=0, description="Width of the angular-acceleration histogram bins, rad/s²."
    )
    accel_max: float = Field(
        50.0, gt=0, description="Top of the acceleration histogram, rad/s²; above: last bin."
    )
    fgd_chunk_s: float = Field(
        2.0, gt=0, description="FGD: motion chunk length, seconds (GENEA: 30/60/90 frames)."
    )
    fgd_rate_hz: float = Field(
        30.0, gt=0, description="FGD: chunks are resampled to this rate, Hz (GENEA's 30 fps)."
    )
    fgd_stride_s: float = Field(0.25, gt=0, description="FGD: hop between chunks, seconds.")
    fgd_features: int = Field(32, ge=2, le=256, description="FGD: autoencoder feature size.")
    fgd_hidden: int = Field(64, ge=4, le=512, description="FGD: conv channels of the autoencoder.")
    fgd_epochs: int = Field(60, ge=1, description="FGD: autoencoder training epochs.")
    fgd_batch_size: int = Field(64, ge=1, description="FGD: autoencoder batch size.")
    fgd_learning_rate: float = Field(1e-3, gt=0, description="FGD: Adam learning rate.")
    beat_sigma_s: float = Field(
        0.3, gt=0, description="Beat consistency: σ of exp(−d²/2σ²), seconds (BEAT: 0.3)."
    )
    beat_min_order_s: float = Field(
        0.25,
        gt=0,
        description="Beat consistency: a motion beat is a speed minimum lower than every frame "
        "this close on either side, seconds (BEAT: 7 frames, ≈ 0.23 s at 30 fps); shorter "
        "counts every jitter of the speed as a beat.",
    )
    onset_delta: float = Field(
        0.07,
        ge=0,
        description="Audio onsets: a peak of the normalised onset strength must exceed its "
        "local mean by this (librosa's default).",
    )
    onset_wait_s: float = Field(
        0.03, ge=0, description="Audio onsets: shortest time between two onsets, seconds."
    )
    onset_window_s: float = Field(
        0.1,
        gt=0,
        description="Audio onsets: half-width of the local mean and of the local-maximum test, "
        "seconds.",
    )
    shuffle_seed: int = Field(
        0, description="Which other clip lends its motion to the 'shuffled clip' baseline."
    )


class MLPConfig(Section):
    layers: int = Field(
        7, ge=1, le=64, description="Hidden layers N_l (Table 4.5: 7 for LogFB-26)."
    )
    units: int = Field(8, ge=1, description="Units per hidden layer N_u (Table 4.5: 8).")
    batch_size: int | None = Field(
        None,
        ge=1,
        description="Frames per Adam step; none = the whole training partition per step, as the "
        "dissertation (one step per epoch). Set e.g. 256 for faster convergence on big data.",
    )
    max_epochs: int = Field(10_000, ge=1, description="Upper bound on epochs (§4.3.3: 10,000).")


class LSTMConfig(Section):
    units: int = Field(12, ge=1, description="LSTM units N_u' in the one hidden layer (§4.3.4).")
    seq_len: int = Field(
        300, ge=2, description="Training sequence length N_τ, frames (300 = 3 s at 100 Hz)."
    )
    stride: int = Field(1, ge=1, description="Frames between training sequence starts (§4.3.4: 1).")
    batch_size: int = Field(
        256,
        ge=1,
        description="Sequences per Adam step. The dissertation used 15,000 (its GPU memory "
        "limit); 256 fits a CPU and converges in fewer epochs.",
    )
    max_epochs: int = Field(100, ge=1, description="Upper bound on epochs (§4.3.4: 100 SI).")


class FCGRUConfig(Section):
    """Seed 001's common network: FC layers (ReLU, batch norm, dropout) → one GRU → linear."""

    fc_layers: int = Field(3, ge=1, description="Fully-connected layers before the GRU ([001]: 3).")
    units: int = Field(256, ge=1, description="Width of the FC layers and the GRU ([001]: 256).")
    dropout: float = Field(0.1, ge=0, lt=1, description="Dropout between layers ([001]: 0.1).")
    learning_rate: float = Field(1e-3, gt=0, description="Adam learning rate ([001]: 0.001).")
    seq_len: int = Field(
        100, ge=2, description="Training chunk length, frames ([001]: 100-frame chunks)."
    )
    stride: int = Field(50, ge=1, description="Frames between training chunk starts.")


class Aud2MotionConfig(FCGRUConfig):
    """Aud2Motion [001]: the common network with a causal, unidirectional GRU; many-to-many."""

    batch_size: int = Field(256, ge=1, description="Chunks per Adam step ([001] English: 256).")
    max_epochs: int = Field(500, ge=1, description="Upper bound on epochs ([001]: 500).")


class Aud2PoseConfig(FCGRUConfig):
    """Aud2Pose [001]: the common network with a BiGRU over a ±C window, many-to-one."""

    context: int = Field(
        30,
        ge=0,
        description="C: frames before and after t in each window ([001]: 30, i.e. 1.5 s at its "
        "20 fps; at 100 Hz 0.3 s unless raised).",
    )
    velocity: bool = Field(
        True, description="Also predict Δg_t as a training regulariser ([001] baseline)."
    )
    batch_size: int = Field(
        20, ge=1, description="Chunks per Adam step (20 × 100 windows ≈ [001]'s batch of 2056)."
    )
    max_epochs: int = Field(120, ge=1, description="Upper bound on epochs ([001]: 120).")


class Aud2Repr2PoseConfig(Section):
    """Aud2Repr2Pose [001]: a motion denoising autoencoder, then a speech encoder (the Aud2Pose
    network, sized and scheduled by `[train.aud2pose]`) trained to its code, chained."""

    code: int = Field(
        8,
        ge=1,
        description="Bottleneck z of the motion DAE. [001]: 325 of 384 inputs (118 on English "
        "data); here the input is 11 angles + their velocities = 22.",
    )
    noise: float = Field(
        0.05, ge=0, description="DAE input noise std, × each dimension's std ([001]: 0.05)."
    )
    dae_learning_rate: float = Field(1e-3, gt=0, description="DAE Adam rate ([001]: 0.001).")
    dae_batch_size: int = Field(128, ge=1, description="DAE frames per step ([001]: 128).")
    dae_epochs: int = Field(20, ge=1, description="DAE epochs ([001]: 20).")


class DCCCAEConfig(Section):
    """D-DCCCAE [003]: a speech and a motion autoencoder over ±`context`-frame segments, their
    codes CCA-constrained; a feed-forward regressor between the codes with the motion decoder
    fine-tuned; overlap-add; an autoencoder post-filter, overlap-added again. [003] gives no
    depths or widths, the CCA's regularisation or the term's weight: all config here."""

    context: int = Field(3, ge=0, description="Segment half-width, frames ([003]: ±3).")
    ae_units: int = Field(128, ge=1, description="Hidden layer of each autoencoder (not in [003]).")
    code: int = Field(16, ge=1, description="Embedding size of each autoencoder (not in [003]).")
    cca_weight: float = Field(
        1.0, ge=0, description="Weight of −CCA beside the reconstruction errors (not in [003])."
    )
    cca_reg: float = Field(
        1e-3, ge=0, description="Ridge added to the covariances of the CCA term (not in [003])."
    )
    regressor_layers: int = Field(2, ge=1, description="Hidden layers of the code regressor.")
    regressor_units: int = Field(128, ge=1, description="Units per regressor hidden layer.")
    post_context: int = Field(
        15, ge=1, description="Post-filter window half-width, frames ([003]: 30-frame windows)."
    )
    post_code: int = Field(32, ge=1, description="Bottleneck of the post-filter autoencoder.")
    learning_rate: float = Field(2e-4, gt=0, description="Adam learning rate ([003]: 0.0002).")
    batch_size: int = Field(
        41, ge=1, description="Chunks per Adam step (41 × 100 frames ≈ [003]'s 4096)."
    )
    max_epochs: int = Field(500, ge=1, description="Upper bound on epochs per stage ([003]: 500).")
    seq_len: int = Field(100, ge=2, description="Training chunk length, frames.")
    stride: int = Field(50, ge=1, description="Frames between training chunk starts.")


class RMSpropScheduleConfig(Section):
    """Seed 004's schedule: RMSprop; when the validation loss stalls, reload the best weights
    and divide the rate by 10, down to the floor; then stop at the best validation loss."""

    learning_rate: float = Field(1e-3, gt=0, description="Initial RMSprop rate ([004]: 1e-3).")
    patience: int = Field(5, ge=1, description="Epochs without improvement per rate ([004]: 5).")
    factor: float = Field(0.1, gt=0, lt=1, description="Rate multiplier at each drop ([004]: 0.1).")
    min_lr: float = Field(1e-5, gt=0, description="Last rate tried ([004]: 1e-5).")


class SpanBLSTMConfig(Section):
    """The BLSTM span predictor [004]: each window of n frames predicts the k frames around its
    centre; the k overlapping predictions of a frame are averaged. Depth and width not stated."""

    layers: int = Field(2, ge=1, description="Stacked bidirectional LSTM layers (not in [004]).")
    units: int = Field(64, ge=1, description="LSTM units per direction (not in [004]).")
    receptive: int = Field(
        61, ge=1, description="n: frames each prediction sees, odd ([004]: 29 ≤ n ≤ 129)."
    )
    span: int = Field(
        5, ge=1, le=29, description="k: frames each window predicts, odd ([004]: 1–29)."
    )
    seq_len: int = Field(100, ge=2, description="Training chunk length, frames.")
    stride: int = Field(50, ge=1, description="Frames between training chunk starts.")
    batch_size: int = Field(32, ge=1, description="Chunks per RMSprop step (not in [004]).")
    max_epochs: int = Field(1000, ge=1, description="Upper bound on epochs (the schedule stops).")


class CVAEConfig(Section):
    """The CVAE [004]: a BLSTM encoder of (motion, audio) → q(z), a BLSTM decoder of (audio, z);
    z ~ N(0, I) at synthesis. Depth and width not stated in [004]."""

    layers: int = Field(2, ge=1, description="BLSTM layers of the encoder and the decoder.")
    units: int = Field(64, ge=1, description="LSTM units per direction (not in [004]).")
    latent: int = Field(3, ge=1, description="Size of z ([004]: 3).")
    kl_weight: float = Field(
        1.0, ge=0, description="Weight of the KL term beside the reconstruction (not in [004])."
    )
    seq_len: int = Field(100, ge=2, description="Training chunk length, frames (one z each).")
    stride: int = Field(50, ge=1, description="Frames between training chunk starts.")
    batch_size: int = Field(32, ge=1, description="Chunks per RMSprop step (not in [004]).")
    max_epochs: int = Field(1000, ge=1, description="Upper bound on epochs (the schedule stops).")


class TrainConfig(Section):
    """How models are trained and evaluated (section `[train]`). Another key must be a plug-in
    model's own `[train.NAME]` section, validated by that model (`registry.plugin_section`)."""

    model_config = ConfigDict(extra="allow", validate_assignment=True, frozen=False)

    mlp: MLPConfig = Field(default_factory=MLPConfig)
    lstm: LSTMConfig = Field(default_factory=LSTMConfig)
    aud2motion: Aud2MotionConfig = Field(default_factory=Aud2MotionConfig)
    aud2pose: Aud2PoseConfig = Field(default_factory=Aud2PoseConfig)
    blstm: SpanBLSTMConfig = Field(default_factory=SpanBLSTMConfig)
    cvae: CVAEConfig = Field(default_factory=CVAEConfig)
    aud2repr2pose: Aud2Repr2PoseConfig = Field(default_factory=Aud2Repr2PoseConfig)
    dcccae: DCCCAEConfig = Field(default_factory=DCCCAEConfig)
    rmsprop: RMSpropScheduleConfig = Field(default_factory=RMSpropScheduleConfig)
    learning_rate: float = Field(1e-3, gt=0, description="Adam learning rate (Keras default).")
    patience: int = Field(
        10, ge=1, description="Stop after this many epochs without a lower validation loss."
    )
    seed: int = Field(0, description="Seeds weights and shuffling; same seed → same weights.")
    threads: int = Field(
        1,
        ge=1,
        description="torch CPU threads while training. These models are tiny: a second thread "
        "made an MLP step slower, not faster (0.6 vs 16–49 ms on 2 busy cores).",
    )
    smoothing_cutoff_hz: float = Field(
        4.0, gt=0, description="Post-smoothing of predictions (§4.4.1): Butterworth cut-off, Hz."
    )
    smoothing_order: int = Field(5, ge=1, le=10, description="Post-smoothing Butterworth order.")
    lcca_window_s: float = Field(3.0, gt=0, description="Local CCA window τ, seconds (§3.4.3).")
    lcca_stride: int = Field(
        1, ge=1, description="Frames between local-CCA windows (Eq. 3.18: 1; raise for speed)."
    )
    shift_baseline_s: float = Field(
        0.5, gt=0, description="Time shift of the 'ground truth shifted' baseline, seconds."
    )
    speed_bin: float = Field(
        0.05, gt=0, description="Width of the angular-speed histogram bins, rad/s."
    )
    speed_max: float = Field(
        5.0,
        gt=0,
        description="Top of the speed histogram, rad/s; faster frames go in the last bin.",
    )
    eval: EvalConfig = Field(default_factory=EvalConfig)

    @model_validator(mode="after")
    def _plugin_sections(self) -> TrainConfig:
        extra = self.__pydantic_extra__ or {}
        for name, raw in extra.items():
            try:
                extra[name] = plugin_section(
                    "gesturebank.models", name, raw, type(self).model_fields
                )
            except ValueError as exc:  # one line, at the [train] table: "NAME.key: problem"
                raise PydanticCustomError("plugin_section", "{why}", {"why": str(exc)}) from None
        return self


class PlaybackConfig(Section):
    """Options of robot playback (offline replay and live mode)."""

    mode: Literal["stream", "interpolate"] = Field(
        "stream",
        description="'stream': one setAngles per frame with the adaptive sleep of Eq. 4.1; "
        "'interpolate': one time-stamped angleInterpolation call for the whole timeline "
        "(backends without it stream). 'stream' kept better sync (benchmarks/playback.py).",
    )
    eta: float = Field(
        0.95,
        gt=0,
        le=1,
        description="η of Eq. 4.1: sleep η × the time left until the next frame is due; below "
        "1 it wakes early rather than late (the dissertation's empirical 0.95).",
    )
    start_s: float = Field(
        2.0, ge=0, description="Shortest move from the robot's current pose to frame 0, seconds."
    )
    return_s: float = Field(
        2.0, ge=0, description="Shortest move back to the neutral pose at the end, seconds."
    )
    lead_s: float = Field(
        0.05,
        ge=0,
        description="Pause between reaching frame 0 and starting the audio, seconds (gives "
        "the audio device time to open).",
    )
    max_speed_fraction: float = Field(
        0.5,
        gt=0,
        le=1,
        description="Cap on each joint's speed as a share of its maximum velocity; also "
        "ALMotion's fractionMaxSpeed. The dissertation used 1.0; 0.5 by default because the "
        "profile's velocities are the motors' no-load maxima (URDF), not a pace to drive a "
        "robot at unasked, while half (3.7 rad/s at the shoulders) still follows a beat of "
        "0.5 rad in a quarter of a second. 1.0 reproduces the dissertation.",
    )
    max_outside_share: float = Field(
        0.05,
        ge=0,
        le=1,
        description="Replay refuses a timeline with more than this share of frames beyond the "
        "robot's limits (or any angle beyond ±2π): radians expected, degrees are the usual "
        "cause. `--clamp` plays it clamped instead.",
    )
    max_gap_s: float = Field(
        0.5,
        gt=0,
        description="Replay refuses a timeline with a longer gap between two frames, seconds "
        "(the robot would hold still, then jump).",
    )
    max_start_s: float = Field(
        5.0,
        ge=0,
        description="Replay refuses a timeline whose first frame comes later than this after "
        "the audio starts, seconds (a timeline on another clock, e.g. the source video's).",
    )
    ramp_rate_hz: float = Field(
        100.0, gt=0, le=1000, description="Command rate of the start and return moves, Hz."
    )
    timeout_s: float = Field(
        2.0,
        gt=0,
        description="A robot call taking longer than this counts as a lost connection, seconds.",
    )
    wake_up: bool = Field(
        True, description="naoqi: call ALMotion.wakeUp (stiffen the motors) before moving."
    )
    rest_at_end: bool = Field(
        False, description="naoqi: call ALMotion.rest (crouch, motors off) after returning."
    )
    kalman_q: float = Field(
        0.5, ge=0, description="Live mode: Kalman process noise q (§4.4.2; dissertation 0.5)."
    )
    kalman_r: float = Field(
        0.01, gt=0, description="Live mode: Kalman measurement noise r (dissertation 0.01)."
    )

    @model_validator(mode="before")
    @classmethod
    def _renamed(cls, data: Any) -> Any:
        # `speed_fraction` became `max_speed_fraction`: datasets and config files that have the
        # old key still load, with its value unless the new key is given too.
        if isinstance(data, dict) and "speed_fraction" in data:
            data = dict(data)
            data.setdefault("max_speed_fraction", data.pop("speed_fraction"))
        if isinstance(data, dict) and ("sim_fps" in data or "sim_view_px" in data):
            # the flat drawing's options, moved to [render] (Config moves them; here, dropped)
            data = {k: v for k, v in data.items() if k not in ("sim_fps", "sim_view_px")}
        return data


class RenderConfig(Section):
    """The `sim` backend's and `stimuli`'s 3D render of Pepper (robot/render3d.py)."""

    frame_rate: int = Field(25, ge=1, le=120, description="Video frame rate, frames/s.")
    width_px: int = Field(640, ge=64, le=3840, description="Width of one robot's view, px.")
    height_px: int = Field(480, ge=64, le=2160, description="Height of the video, px.")
    azimuth_deg: float = Field(
        30.0,
        ge=-180,
        le=180,
        description="Camera direction around the robot: 0 straight in front, positive towards "
        "its left (30: a front three-quarter view).",
    )
    elevation_deg: float = Field(
        6.0, ge=-30, le=80, description="Camera height as an angle above the horizon, degrees."
    )
    distance_m: float = Field(
        2.7, gt=0.5, le=20, description="Camera distance from the middle of the robot, metres."
    )
    fov_deg: float = Field(
        32.0, gt=5, lt=120, description="Vertical field of view of the camera, degrees."
    )
    ramps: bool = Field(
        True,
        description="sim replay: also show the safety moves (start move to frame 0 and the "
        "return to neutral), the audio starting where the timeline does.",
    )


class SplitsConfig(Section):
    folds: int = Field(
        10, ge=2, description="Subject-independent folds (Table 4.4: 10; capped at the subjects)."
    )
    seed: int = Field(0, description="Shuffles the subjects before they are cut into folds.")
    sd_fractions: tuple[float, float, float] = Field(
        (0.70, 0.15, 0.15),
        description="Subject-dependent split: train, validation, test shares of each subject's "
        "recordings, in time order.",
    )
    include_rejected: bool = Field(
        False, description="Put takes the QC rejected into the splits too (failed ones never)."
    )

    @model_validator(mode="after")
    def _fractions(self) -> SplitsConfig:
        if min(self.sd_fractions) < 0 or abs(sum(self.sd_fractions) - 1) > 1e-9:
            raise ValueError("sd_fractions must be three non-negative numbers summing to 1")
        return self


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


SynthLook = Literal["tshirt", "sleeves"]


class SynthConfig(Section):
    """Ground-truth renders of a BVH (`gesturebank render`, gesturebank/synth/): cameras
    around the figure, its look, the stretch of the motion."""

    azimuths_deg: list[float] = Field(
        default_factory=lambda: [0.0],
        description="One camera per entry: its direction around the person, degrees (0 in front "
        "of the person's mean facing direction, positive towards their left).",
    )
    rig_spread_deg: float = Field(
        90.0,
        gt=0,
        le=360,
        description="`gesturebank render --cameras N`: the N cameras spread evenly over this "
        "many degrees, centred on the first azimuth.",
    )
    elevation_deg: float = Field(
        0.0, ge=-60, le=80, description="Camera height as an angle above the horizon, degrees."
    )
    distance_m: float = Field(
        3.0, gt=0.5, le=30, description="Camera distance from the figure's chest, metres."
    )
    fov_deg: float = Field(
        50.0, gt=5, lt=150, description="Vertical field of view of every camera, degrees."
    )
    width_px: int = Field(1280, ge=32, le=3840, description="Video width, px (even).")
    height_px: int = Field(720, ge=32, le=2160, description="Video height, px (even).")
    rate_fps: float = Field(30.0, gt=0, le=240, description="Video frame rate, frames/s.")
    start_s: float = Field(0.0, ge=0, description="Where in the BVH the render starts, s.")
    length_s: float | None = Field(
        None, gt=0, description="How much of the BVH is rendered, s (none: to its end)."
    )
    look: SynthLook = Field(
        "tshirt",
        description="Clothing, skin and background: 'tshirt' (short sleeves, light wall) or "
        "'sleeves' (long sleeves, darker skin, brick wall).",
    )
    supersample: int = Field(
        1,
        ge=1,
        le=4,
        description="Rays per pixel along each axis, averaged (anti-aliasing; the cost grows "
        "with its square).",
    )

    @model_validator(mode="after")
    def _even(self) -> SynthConfig:
        if self.width_px % 2 or self.height_px % 2:
            raise ValueError("width_px and height_px must be even (yuv420p video)")
        if not self.azimuths_deg:
            raise ValueError("azimuths_deg needs at least one camera")
        return self


Executor = Literal["local", "ray"]


class BuildConfig(Section):
    workers: int | None = Field(
        None, ge=1, description="Takes built in parallel (none = number of CPU cores)."
    )
    executor: Executor = Field("local", description="'local' process pool, or 'ray' for a cluster.")
    ray_address: str | None = Field(
        None,
        description="Ray cluster address: 'auto', host:port or ray://host:port (none = "
        "RAY_ADDRESS, else a private Ray on this machine).",
    )
    ray_max_retries: int = Field(
        2, ge=0, description="Times Ray reruns a take whose worker or node died, elsewhere."
    )
    ray_memory_base_mb: float = Field(
        450.0,
        gt=0,
        description="Memory a take's Ray task asks for before its frames (a 7 s 1080p take "
        "peaked at 430 MB).",
    )
    ray_memory_per_frame_kb: float = Field(
        40.0,
        ge=0,
        description="Memory per video frame a take's Ray task asks for on top (pose, audio "
        "and angle arrays kept for the whole take; a take's peak grew by 37 kB a frame from "
        "1 to 3 minutes of 30 fps video).",
    )
    ray_connect_timeout_s: float = Field(
        10.0, gt=0, description="Wait for the Ray head to answer before giving up."
    )
    ray_check_timeout_s: float = Field(
        60.0, gt=0, description="Wait for every Ray node's storage check (and for cancelled tasks)."
    )
    decode_threads: int | None = Field(
        None,
        ge=1,
        description="FFmpeg threads decoding one video (none = CPU cores / workers: a lone "
        "worker decodes on the spare cores, a full pool does not oversubscribe them; "
        "1 for Ray tasks, which ask Ray for the larger of the two thread counts in CPUs).",
    )
    inference_threads: int | None = Field(
        None,
        ge=1,
        description="Threads of each detector model interpreter (none = CPU cores / workers, so "
        "workers × threads ≈ cores; 1 for Ray tasks).",
    )
    cache_detections: bool = Field(
        True,
        description="Reuse 2D detections of a video already seen with the same detector "
        "settings (cached by content in the user cache dir, or $GESTUREBANK_CACHE).",
    )
    chunk_s: float | None = Field(
        600.0,
        gt=0,
        description="Videos longer than this are detected in time chunks of about this length, "
        "each a task of its own (so one long video uses every worker), and the chunks' people "
        "stitched into one take; none = one task per video. Chunks are cached in OUT_DIR's "
        ".detections folder, which every worker sees.",
    )
    chunk_overlap_s: float = Field(
        5.0,
        ge=0,
        description="Each chunk after the first starts this much before its own part: the "
        "detector's tracking settles there and the people are matched to the previous chunk's.",
    )
    video_extensions: list[str] = Field(
        [".mp4", ".mov", ".avi", ".mkv", ".webm"], description="Files treated as takes."
    )
    subject_pattern: str | None = Field(
        None,
        description="Regular expression with a group 'subject' matched against a take's "
        "relative path, used when there is no subjects.csv.",
    )


class Config(Section):
    """The resolved configuration of every stage."""

    video: VideoConfig = Field(default_factory=VideoConfig)
    detector: DetectorConfig = Field(default_factory=DetectorConfig)
    shots: ShotsConfig = Field(default_factory=ShotsConfig)
    tracking: TrackingConfig = Field(default_factory=TrackingConfig)
    repair: RepairConfig = Field(default_factory=RepairConfig)
    clips: ClipsConfig = Field(default_factory=ClipsConfig)
    lifter: LifterConfig = Field(default_factory=LifterConfig)
    geometric: GeometricConfig = Field(default_factory=GeometricConfig)
    fitted: FittedConfig = Field(default_factory=FittedConfig)
    resolved: ResolvedConfig = Field(default_factory=ResolvedConfig)
    multiview: MultiviewConfig = Field(default_factory=MultiviewConfig)
    board: BoardConfig = Field(default_factory=BoardConfig)
    robot: RobotConfig = Field(default_factory=RobotConfig)
    retarget: RetargetConfig = Field(default_factory=RetargetConfig)
    processing: ProcessingConfig = Field(default_factory=ProcessingConfig)
    audio: AudioConfig = Field(default_factory=AudioConfig)
    speech: SpeechConfig = Field(default_factory=SpeechConfig)
    qc: QCConfig = Field(default_factory=QCConfig)
    splits: SplitsConfig = Field(default_factory=SplitsConfig)
    train: TrainConfig = Field(default_factory=TrainConfig)
    playback: PlaybackConfig = Field(default_factory=PlaybackConfig)
    render: RenderConfig = Field(default_factory=RenderConfig)
    mocap: MocapConfig = Field(default_factory=MocapConfig)
    synth: SynthConfig = Field(default_factory=SynthConfig)
    build: BuildConfig = Field(default_factory=BuildConfig)

    @model_validator(mode="before")
    @classmethod
    def _moved(cls, data: Any) -> Any:
        # playback.sim_fps became render.frame_rate (datasets and config files with it still load)
        playback = data.get("playback") if isinstance(data, dict) else None
        if isinstance(playback, dict) and "sim_fps" in playback:
            render = dict(data.get("render") or {})
            render.setdefault("frame_rate", playback["sim_fps"])
            data = {**data, "render": render}
        return data

    def to_json_dict(self) -> dict[str, Any]:
        return self.model_dump(mode="json")

    def digest(self, *sections: str) -> str:
        """sha256 of the given sections (all when none), to key caches and resumable builds."""
        data = self.to_json_dict()
        if sections:
            data = {s: data[s] for s in sections}
        return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:16]


def commented_example() -> str:
    """The commented gesturebank.toml shipped in the package: every key, its unit, its default."""
    return resources.files("gesturebank").joinpath("data/gesturebank.toml").read_text("utf-8")


def _error_line(source: str, exc: ValidationError, text: str | None = None) -> str:
    """One line per problem, naming the dotted key: 'file.toml:7: audio.nfilt: ...'.

    An unknown key names the nearest valid one ("did you mean max_epochs?"); with the file's
    `text`, the line of the key is given too.
    """
    lines = []
    for err in exc.errors():
        loc = tuple(str(p) for p in err["loc"])
        key = ".".join(loc) or "(top level)"
        msg = err["msg"]
        if err["type"] == "extra_forbidden":
            msg = "unknown key" + _suggestion(loc)
        elif "input" in err and not isinstance(err["input"], dict | list):
            msg = f"{msg} (got {err['input']!r})"
        line = _line_of(text, loc) if text is not None else None
        where = source if line is None else f"{source}:{line}"
        lines.append(f"{where}: {key}: {msg}")
    return "; ".join(lines)


def _section_model(path: tuple[str, ...]) -> type[BaseModel] | None:
    """The config model at a dotted path of sections (None when the path leaves the models)."""
    model: type[BaseModel] = Config
    for name in path:
        field = model.model_fields.get(name)
        inner = field.annotation if field is not None else None
        if not (isinstance(inner, type) and issubclass(inner, BaseModel)):
            return None
        model = inner
    return model


def _suggestion(loc: tuple[str, ...]) -> str:
    """' (did you mean NAME?)' for an unknown key, from the valid keys of its section (or
    them all, when none is close and they are few)."""
    model = _section_model(loc[:-1])
    if model is None or not loc:
        return ""
    keys = list(model.model_fields)
    close = difflib.get_close_matches(loc[-1], keys, n=1, cutoff=0.6)
    if close:
        return f" (did you mean {close[0]}?)"
    return f" (valid: {', '.join(keys)})" if len(keys) <= 12 else " (see `gesturebank config`)"


_TABLE = re.compile(r"^\s*\[\[?\s*([^\]]+?)\s*\]\]?")
_KEY = re.compile(r"^\s*([A-Za-z0-9_\-.\"' ]+?)\s*=")


def _dotted(name: str) -> tuple[str, ...]:
    return tuple(part.strip().strip("\"'") for part in name.split("."))


def _line_of(text: str, loc: tuple[str, ...]) -> int | None:
    """1-based line of the TOML `text` that defines the key at `loc` (or opens its table)."""
    table: tuple[str, ...] = ()
    for number, line in enumerate(text.splitlines(), start=1):
        if m := _TABLE.match(line):
            table = _dotted(m.group(1))
            if table[: len(loc)] == loc:  # an unknown section: its header
                return number
        elif m := _KEY.match(line):
            path = (*table, *_dotted(m.group(1)))
            if path[: len(loc)] == loc:
                return number
    return None


def _merge(base: dict[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, Mapping) and isinstance(out.get(k), dict) else v
    return out


def parse_override(item: str) -> dict[str, Any]:
    """'audio.nfilt=40' → {'audio': {'nfilt': 40}}; the value is read as TOML (else a string)."""
    key, sep, raw = item.partition("=")
    if not sep or not key.strip():
        raise ConfigError(f"--set {item!r}: expected SECTION.KEY=VALUE")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()
    nested: dict[str, Any] = {}
    cur = nested
    parts = key.strip().split(".")
    for p in parts[:-1]:
        cur = cur.setdefault(p, {})
    cur[parts[-1]] = value
    return nested


def load_config(
    path: str | os.PathLike[str] | None = None,
    overrides: Iterable[Mapping[str, Any]] = (),
    *,
    base: Config | None = None,
) -> Config:
    """Defaults (or `base`) < the TOML file at `path` < each mapping of `overrides` in turn.

    Raises ConfigError with one line naming the file (or "command line") and the key.
    """
    data: dict[str, Any] = {} if base is None else base.to_json_dict()
    source = "defaults"
    if path is not None:
        source = os.fspath(path)
        try:
            text = Path(path).read_text(encoding="utf-8")
            from_file = tomllib.loads(text)
        except FileNotFoundError:
            raise ConfigError(f"{source}: config file not found") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise ConfigError(f"{source}: cannot read config file ({exc})") from None
        except tomllib.TOMLDecodeError as exc:
            raise ConfigError(f"{source}: not valid TOML ({exc})") from None
        try:
            Config.model_validate(from_file)
        except ValidationError as exc:
            raise ConfigError(_error_line(source, exc, text)) from None
        data = _merge(data, from_file)
    for over in overrides:
        data = _merge(data, over)
    try:
        return Config.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(_error_line("command line", exc)) from None
