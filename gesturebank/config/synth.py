"""Options of the truth renderer (`[synth]`): cameras, look and the stretch of motion drawn."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from gesturebank.config.section import Section

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
