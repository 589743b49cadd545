"""Options of the 3D lifters: which one (`[lifter]`), each lifter's own section
(`[lifter.geometric]`, `[lifter.fitted]`, `[lifter.resolved]`, `[lifter.learned]`,
`[lifter.multiview]`, a plug-in's `[lifter.NAME]`) and the calibration board (`[board]`).
"""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import Field, model_validator

from gesturebank.config.section import PluginSections, Section


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
    learned_weight: float = Field(
        0.0,
        ge=0,
        description="Cost of a bone pointing away from the `learned` lifter's 3D (its network "
        "run on the same 2D), per squared unit-vector difference; 0 does not run it.",
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


class LearnedConfig(Section):
    """Options of the `learned` lifter: a temporal convolution net (ONNX) from 2D to 3D."""

    onnx_file: str = Field(
        "",
        description="The lifter's ONNX file; empty = the one shipped in the package "
        "(gesturebank/data/learned-lifter.onnx, trained by benchmarks/train_lifter.py). Its "
        "sidecar (same name, .json) must sit beside it.",
    )
    threads: int = Field(
        1,
        ge=1,
        description="onnxruntime threads of one lift (a build already lifts takes in parallel "
        "workers).",
    )
    mirror_average: bool = Field(
        True,
        description="Also lift the 2D flipped left-right and average it, mirrored back, with the "
        "direct lift: a left-right flip of the video then changes only what the detector sees "
        "(twice the net's time, which is tiny beside the detector's).",
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

    refine_cameras: bool = Field(
        False,
        description="Before triangulating, refine the calibration from the person's own "
        "keypoints: a bundle adjustment (pycolmap) of the cameras' poses and the joints "
        "together, the reference camera's pose and every camera's intrinsics held fixed, the "
        "scale kept at the calibration's mean baseline. For a rig whose cameras were moved or "
        "calibrated roughly. Off by default: a detector's 2D is not consistent enough between "
        "views to improve a good calibration (renders of test.bvh, BlazePose, 3-4 cameras: a "
        "true calibration moves by 0.6-2.1° and 2-8 cm, hand error 3.2 -> 3.5 cm with 3 cameras; "
        "from cameras 5° and 10 cm off it comes back to 0.6-1.1° and 2-3 cm).",
    )
    bundle_frames: int = Field(
        60,
        ge=3,
        description="Camera refinement: most frames whose joints are adjusted (chosen evenly "
        "over the take among those with the most confident keypoints).",
    )
    bundle_min_confidence: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Camera refinement: 2D keypoints below this confidence are not used.",
    )
    bundle_loss_px: float = Field(
        4.0,
        gt=0,
        description="Camera refinement: scale of the robust (Cauchy) loss, pixels: "
        "reprojection errors well above it (a swapped or wrong keypoint) pull little.",
    )

    @model_validator(mode="after")
    def _reject(self) -> MultiviewConfig:
        if self.reject_error_px is not None and self.reject_error_px < self.max_error_px:
            raise ValueError("reject_error_px must be at least max_error_px")
        return self


class LifterConfig(PluginSections):
    """`[lifter]`: which lifter lifts single-view takes (`name`), and each lifter's own
    `[lifter.NAME]` (a plug-in's validated by it)."""

    plugin_group: ClassVar[str] = "gesturebank.lifters"

    name: str = Field(
        "learned",
        description="3D lifter of single-view takes: 'learned' (a temporal convolution net "
        "trained on projected motion capture; the most accurate on the truth benchmark), "
        "'blazepose-world' (BlazePose's own 3D landmarks), 'fitted' (a skeleton fitted to the 2D "
        "with BlazePose's 3D as prior), 'resolved' (each arm bone's depth sign decoded over the "
        "take), 'geometric' (assumptions) or a plug-in name; multi-camera takes always use "
        "'multiview'.",
    )
    geometric: GeometricConfig = Field(default_factory=GeometricConfig)
    fitted: FittedConfig = Field(default_factory=FittedConfig)
    resolved: ResolvedConfig = Field(default_factory=ResolvedConfig)
    learned: LearnedConfig = Field(default_factory=LearnedConfig)
    multiview: MultiviewConfig = Field(default_factory=MultiviewConfig)


# The top-level lifter sections of the release before, now `[lifter.NAME]` (Config reads them).
OLD_LIFTER_SECTIONS = ("geometric", "fitted", "resolved", "learned", "multiview")


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
