"""Options of the robot: its profile (`[robot]`), the retargeting (`[retarget]`), playback
(`[playback]`) and the 3D render of Pepper (`[render]`).
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, model_validator

from gesturebank.config.section import Section


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
    head_source: Literal["face", "body"] = Field(
        "face",
        description="Where HeadYaw, HeadPitch and head_roll come from in a video: 'face' (the "
        "face landmark model's mesh fitted to a reference face where a face is found, the "
        "body's face keypoints elsewhere; each clip's head_source says which per frame) or "
        "'body' (the body's face keypoints only: nose, eyes, ears).",
    )
    head_max_face_turn: float = Field(
        2.75,
        gt=0,
        description="Faces whose nose lies up to this many half eye distances from the eyes' "
        "midpoint along the eye line (about tan(yaw): 2.75 = 70°) get a face crop for the "
        "head's pose (the mouth takes speech.max_face_turn).",
    )
    head_min_face_px: float = Field(
        24.0,
        gt=0,
        description="Faces narrower than this (pixels, estimated from the eyes) get no face crop "
        "for the head's pose (the mouth takes speech.min_face_px).",
    )
    head_max_fit_residual: float = Field(
        0.05,
        gt=0,
        description="A face mesh whose upper face fits the reference face worse than this (RMS, "
        "share of the face's height) gives no head pose.",
    )


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
