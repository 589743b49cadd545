"""Options of the dataset build: cutting takes into clips (`[clips]`), processing the angles
(`[processing]`), the splits (`[splits]`) and running the build (`[build]`).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from gesturebank.config.section import Section


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
    max_part_unseen_fraction: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Each body part (head, left arm, right arm) is judged on its own: a part "
        "whose angles are unknown in more than this share of a clip is masked whole, and the "
        "clip keeps the others (its `parts`); a clip with no part left is rejected.",
    )

    @model_validator(mode="after")
    def _lengths(self) -> ClipsConfig:
        if self.max_s is not None and self.max_s < self.min_s:
            raise ValueError("max_s must be at least min_s")
        return self


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
    dyadic_fractions: tuple[float, float, float] = Field(
        (0.85, 0.10, 0.05),
        description="Dyadic split (seed 004 §5: 85 / 10 / 5 %): train, validation, test shares "
        "of the clips, a clip always in its partner's part.",
    )

    @model_validator(mode="after")
    def _fractions(self) -> SplitsConfig:
        for name in ("sd_fractions", "dyadic_fractions"):
            fractions = getattr(self, name)
            if min(fractions) < 0 or abs(sum(fractions) - 1) > 1e-9:
                raise ValueError(f"{name} must be three non-negative numbers summing to 1")
        return self


Executor = Literal["local", "ray"]
People = Literal["speaker", "all"]


class BuildConfig(Section):
    people: People = Field(
        "speaker",
        description="Whom a take's clips follow: 'speaker', the main speaker of each shot (the "
        "one who speaks); 'all', every tracked person with usable clips, each clip one "
        "person's (changes what a take holds: takes are built again).",
    )
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
        description="A worker's thread budget for computing: the threads of each detector model "
        "interpreter and of OpenCV's pool (the crops and resizes around the models). None = the "
        "cores this process may use / workers, so that workers × threads ≈ cores and no two "
        "workers' pools fight over a core; 1 for Ray tasks.",
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
