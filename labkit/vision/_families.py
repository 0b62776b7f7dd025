"""Marker families: a registry of data (name -> OpenCV dictionary and bit count).

Adding a family is one entry in :data:`FAMILIES`.

Examples
--------
>>> family_info("tag36h11").bits
6
>>> marker_texture("tag36h11", 0, pixels_per_bit=2).shape  # 6 bits, the black border, 2 white bits each side
(24, 24)
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from labkit.exceptions import OptionError, needs_extra
from labkit.validation import as_count, as_number

__all__ = ["FAMILIES", "MarkerFamily", "family_info", "marker_texture"]


@dataclasses.dataclass(frozen=True)
class MarkerFamily:
    """One marker family.

    Attributes
    ----------
    name : str
        labkit's name (``"tag36h11"``).
    opencv : str
        Name of the ``cv2.aruco`` predefined dictionary.
    bits : int
        Data bits along a side (the black border adds one more on each side).
    count : int
        Number of ids (0 .. count - 1).
    """

    name: str
    opencv: str
    bits: int
    count: int


#: every marker family labkit detects and prints
FAMILIES = {f.name: f for f in (
    MarkerFamily("tag36h11", "DICT_APRILTAG_36h11", 6, 587),
    MarkerFamily("tag25h9", "DICT_APRILTAG_25h9", 5, 35),
    MarkerFamily("aruco4x4_50", "DICT_4X4_50", 4, 50),
    MarkerFamily("aruco5x5_100", "DICT_5X5_100", 5, 100),
    MarkerFamily("aruco6x6_250", "DICT_6X6_250", 6, 250),
)}

#: white quiet zone printed around a marker [bits]
QUIET_ZONE_BITS = 2
#: the most texture pixels per bit and quiet-zone bits a marker texture takes (a 36h11 texture stays under 4,000 px)
MAX_PIXELS_PER_BIT = 256
MAX_QUIET_ZONE_BITS = 16
#: the longest printed side a marker or board square takes [m] (a sheet of paper is 0.3 m; a wall poster 2 m)
MAX_PRINTED = 10.0


def as_length(value, name):
    """``value`` as a printed length [m]: a finite number in (0, :data:`MAX_PRINTED`].

    Parameters
    ----------
    value : float
        A marker's black square or a board's square [m].
    name : str
        What it is, for the message.

    Returns
    -------
    float

    Raises
    ------
    OptionError
        Not a number, not finite, not positive or longer than :data:`MAX_PRINTED`.
    """
    out = as_number(value, name, unit="m", positive=True, error=OptionError)
    if out > MAX_PRINTED:
        raise OptionError(f"expected {name} at most {MAX_PRINTED:g} m (a printed marker or board), got {value!r}")
    return out


def family_info(family):
    """The :class:`MarkerFamily` of a name.

    Parameters
    ----------
    family : str
        A key of :data:`FAMILIES`.

    Returns
    -------
    MarkerFamily

    Raises
    ------
    OptionError
        Unknown family (the message lists the known ones).
    """
    try:
        return FAMILIES[family]
    except (KeyError, TypeError):
        raise OptionError(f"expected a marker family, one of {sorted(FAMILIES)}, got {family!r}") from None


@functools.lru_cache(maxsize=None)
def dictionary(family):
    """The ``cv2.aruco.Dictionary`` of a family (cached).

    Parameters
    ----------
    family : str

    Returns
    -------
    cv2.aruco.Dictionary
    """
    with needs_extra("vision"):
        import cv2

    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, family_info(family).opencv))


def marker_texture(family, marker_id, *, pixels_per_bit=16, quiet_zone=QUIET_ZONE_BITS):
    """Reflectance image of one marker with its white quiet zone (1 = white paper).

    Parameters
    ----------
    family : str
    marker_id : int
    pixels_per_bit : int
        Texture pixels per bit (1 to :data:`MAX_PIXELS_PER_BIT`).
    quiet_zone : int
        White bits around the black border (0 to :data:`MAX_QUIET_ZONE_BITS`).

    Returns
    -------
    ndarray, shape (k, k), float32
        ``k = (bits + 2 + 2 * quiet_zone) * pixels_per_bit``; the black square (the
        marker's printed *size*) is the middle ``(bits + 2) * pixels_per_bit``.

    Raises
    ------
    OptionError
        An id outside the family, or a pixel count or quiet zone that is not a whole number in range.
    """
    with needs_extra("vision"):
        import cv2

    info = family_info(family)
    marker_id = as_count(marker_id, f"a {family} id", maximum=info.count - 1)
    pixels_per_bit = as_count(pixels_per_bit, "pixels_per_bit", minimum=1, maximum=MAX_PIXELS_PER_BIT)
    quiet_zone = as_count(quiet_zone, "quiet_zone", maximum=MAX_QUIET_ZONE_BITS)
    side = (info.bits + 2) * pixels_per_bit
    img = cv2.aruco.generateImageMarker(dictionary(family), int(marker_id), side, borderBits=1)
    pad = quiet_zone * pixels_per_bit
    img = np.pad(img, pad, constant_values=255)
    return (img.astype(np.float32) / 255.0)


def texture_extent(family, size, quiet_zone=QUIET_ZONE_BITS):
    """Printed side of a marker texture with its quiet zone [m] for a black square of ``size`` [m].

    Parameters
    ----------
    family : str
    size : float
        Side of the black square [m].
    quiet_zone : int
        White bits around it.

    Returns
    -------
    float
        Side of the texture [m].
    """
    bits = family_info(family).bits + 2
    return size * (bits + 2 * quiet_zone) / bits
