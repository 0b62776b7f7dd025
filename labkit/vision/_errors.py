"""The errors of :mod:`labkit.vision` (all :class:`labkit.exceptions.LabkitError` subclasses)."""

from __future__ import annotations

from labkit.exceptions import LabkitError

__all__ = ["VisionError", "MarkerNotFoundError", "WrongMarkerError", "AmbiguousPoseError",
           "CalibrationImageError", "HandEyeWarning"]


class VisionError(LabkitError, ValueError):
    """An image, a camera model or a calibration input is not what was expected."""


class MarkerNotFoundError(VisionError):
    """No marker of the expected family was detected in an image."""


class WrongMarkerError(VisionError):
    """Markers were detected, but not the one (or ones) asked for."""


class AmbiguousPoseError(VisionError):
    """The two pose solutions of a square marker (IPPE) fit the corners about equally well.

    The marker is seen too nearly face-on, too small or too blurred for its tilt to be
    known; tilt the marker (or the camera) by 20 deg or more, or move closer.
    """


class CalibrationImageError(VisionError):
    """A calibration board was found in too few images to calibrate the camera."""


class HandEyeWarning(UserWarning):
    """The views of a hand-eye calibration are too alike for a trustworthy result."""
