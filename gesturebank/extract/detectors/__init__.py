"""2D detectors, registered by name; plug-ins use the entry-point group `gesturebank.detectors`."""

from gesturebank.registry import Registry

DETECTORS: Registry[object] = Registry("detector", "gesturebank.detectors")
