"""Image input: any grey or colour image as the 8-bit grey image the detectors take."""

from __future__ import annotations

import numpy as np

from labkit.exceptions import ShapeError, needs_extra

__all__ = ["as_gray"]


def as_gray(image):
    """An image as 8-bit grey.

    Parameters
    ----------
    image : ndarray, shape (h, w) or (h, w, 3) or (h, w, 4)
        Grey, BGR or BGRA image.

    Returns
    -------
    ndarray, shape (h, w), uint8

    Raises
    ------
    ShapeError
        Not an image shape.
    """
    with needs_extra("vision"):
        import cv2

    img = np.asarray(image)
    if img.ndim == 3 and img.shape[2] in (3, 4):
        img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY if img.shape[2] == 3 else cv2.COLOR_BGRA2GRAY)
    if img.ndim != 2:
        raise ShapeError(f"expected a grey (h, w) or colour (h, w, 3) image, got shape {img.shape}")
    if img.dtype != np.uint8:
        img = np.clip(img, 0, 255).astype(np.uint8)
    return img
