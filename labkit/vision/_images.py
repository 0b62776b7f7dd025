"""Image input: any grey or colour image as the 8-bit grey image the detectors take, and image sizes."""

from __future__ import annotations

import numbers

import numpy as np

from labkit.exceptions import ShapeError, VisionError, needs_extra

__all__ = ["as_gray", "image_size", "MIN_SIDE", "MAX_SIDE"]

#: the smallest image side the detectors take [px] (they look at it at half resolution; OpenCV's checkerboard
#: search fails below 30 px)
MIN_SIDE = 32
#: the largest image side [px] (OpenCV keeps some image coordinates in 16-bit integers)
MAX_SIDE = 32767


def _sides_in_range(w, h):
    return MIN_SIDE <= w <= MAX_SIDE and MIN_SIDE <= h <= MAX_SIDE


def as_gray(image):
    """An image as 8-bit grey.

    Parameters
    ----------
    image : ndarray, shape (h, w) or (h, w, 3) or (h, w, 4)
        Grey, BGR or BGRA image: integers, or finite floats (clipped to 0-255), each side
        :data:`MIN_SIDE` to :data:`MAX_SIDE` px.

    Returns
    -------
    ndarray, shape (h, w), uint8

    Raises
    ------
    ShapeError
        Not an image: another shape or size, not numbers, or non-finite values; the
        message says what was expected and what was received.
    """
    with needs_extra("vision"):
        import cv2

    img = np.asarray(image) if isinstance(image, np.ndarray) else None
    if img is None:
        try:
            img = np.asarray(image)
        except (TypeError, ValueError) as exc:
            raise ShapeError(f"expected an image as an array, got {type(image).__name__} ({exc})") from None
    if img.dtype.kind not in "biuf":
        raise ShapeError(f"expected an image of integers or floats, got an array of dtype {img.dtype}")
    if img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] not in (1, 3, 4)):
        raise ShapeError(f"expected a grey (h, w) or colour (h, w, 3) image, got shape {img.shape}")
    if not _sides_in_range(img.shape[1], img.shape[0]):
        raise ShapeError(f"expected an image of {MIN_SIDE} to {MAX_SIDE} px a side, got shape {img.shape}")
    if img.dtype.kind == "f" and not np.isfinite(img).all():
        raise ShapeError("expected an image of finite values, got NaN or infinity")
    if img.dtype != np.uint8:
        img = np.clip(img, 0, 255).astype(np.uint8)
    if img.ndim == 3:
        img = img[:, :, 0] if img.shape[2] == 1 else \
            cv2.cvtColor(img, cv2.COLOR_BGR2GRAY if img.shape[2] == 3 else cv2.COLOR_BGRA2GRAY)
    return img


def image_size(value, name="image_size"):
    """An image size ``(width, height)`` as two ints, checked.

    Parameters
    ----------
    value : sequence of 2 numbers
        Width and height [px], whole numbers from :data:`MIN_SIDE` to :data:`MAX_SIDE`.
    name : str
        The argument's name, for the message.

    Returns
    -------
    tuple of int
        ``(width, height)`` [px].

    Raises
    ------
    VisionError
        Anything else, with what was expected and what was received.

    Examples
    --------
    >>> image_size((640.0, 480))
    (640, 480)
    """
    want = f"expected {name} as two whole numbers (width, height) of {MIN_SIDE} to {MAX_SIDE} px"
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise VisionError(f"{want}, got {value!r}")
    sides = []
    for v in value:
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real) or not float(v).is_integer():
            raise VisionError(f"{want}, got {value!r}")
        sides.append(int(v))
    if not _sides_in_range(*sides):
        raise VisionError(f"{want}, got {value!r}")
    return tuple(sides)
