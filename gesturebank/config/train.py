"""Options of training (`[train]`): the loop, each model's own section (`[train.mlp]` …) and the
field's measures (`[train.eval]`).
"""

from __future__ import annotations

from typing import Literal

from pydantic import ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError

from gesturebank.config.section import Section
from gesturebank.registry import plugin_section

Variant = Literal["si", "sd", "dyadic"]
# Whose head a model predicts (seed 004): the speaker's motion from their own speech (every
# model before), or a listener's head from the partner's speech.
Target = Literal["speaker", "listener"]


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
    target: Target = Field(
        "speaker",
        description="What the model predicts: 'speaker' (the clip's person's motion from the "
        "speech) or 'listener' (seed 004: a listener's head from the partner's speech; input "
        "the audio features plus the partner's speaking flag, loss on listening frames).",
    )
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
    min_train_s: float = Field(
        60.0,
        ge=0,
        description="`train` warns when the train part holds fewer seconds than this: a model "
        "learns little from less (the demo's 5 s of one speaker: worse than the mean pose).",
    )
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
                    "gesturebank.models", name, raw=raw, known=type(self).model_fields
                )
            except ValueError as exc:  # one line, at the [train] table: "NAME.key: problem"
                raise PydanticCustomError("plugin_section", "{why}", {"why": str(exc)}) from None
        return self
