"""One exception family for the whole toolkit (docs/architecture.md "Errors").

Every message is meant to be shown to a user as one line: it names the file or key and the problem.
"""


class GesturebankError(Exception):
    """Root of every error gesturebank raises on purpose."""


class InputError(GesturebankError):
    """A bad input file or directory (unreadable, corrupt, wrong content)."""


class ConfigError(InputError):
    """A bad configuration key or value."""


class DetectionError(GesturebankError):
    """A 2D detector failed or found nothing usable."""


class CalibrationError(GesturebankError):
    """Camera calibration could not be read or estimated."""


class RobotError(GesturebankError):
    """Talking to the robot (or a robot backend) failed."""


class FetchError(GesturebankError):
    """Sample media could not be fetched or failed its checksum."""


class GesturebankDeprecationWarning(DeprecationWarning):
    """Something of gesturebank's read for one more release (an old config key, a manifest row
    read as a dict). The command line shows it; Python shows a DeprecationWarning only when
    `__main__` raises it."""
