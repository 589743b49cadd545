"""gesturebank: videos of people speaking → speech-and-motion datasets for the Pepper robot."""

from gesturebank.errors import (
    CalibrationError,
    ConfigError,
    DetectionError,
    FetchError,
    GesturebankError,
    InputError,
    RobotError,
)

__version__ = "0.1.0"

__all__ = [
    "CalibrationError",
    "ConfigError",
    "DetectionError",
    "FetchError",
    "GesturebankError",
    "InputError",
    "RobotError",
    "__version__",
]
