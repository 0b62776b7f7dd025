"""Calibration boards: a checkerboard and a ChArUco board (printable, renderable, detectable).

A board's frame has its origin at the centre of the printed sheet, x to the
right, y up, z out of the printed face, like a marker's. Sizes in m.

Examples
--------
>>> board = Checkerboard(columns=9, rows=6, square=0.025)
>>> board.object_points().shape
(54, 3)
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from labkit.exceptions import OptionError, needs_extra
from labkit.validation import as_count, as_number
from labkit.vision._families import as_length, dictionary, family_info
from labkit.vision._images import as_gray

__all__ = ["Checkerboard", "CharucoBoard"]

#: the most inner corners (or squares) along a side, and white margin in squares, a board takes
MAX_SIDE_COUNT = 100
MAX_MARGIN = 10.0
#: the most texture pixels per square (a texture's side stays under OpenCV's 32767 px for boards up to 30 squares)
MAX_PIXELS_PER_SQUARE = 1024


def _check_board(board, least, lengths):
    """Check and normalise a board's counts (at least ``least`` a side), ``lengths`` [m] and margin in place."""
    owner = type(board).__name__
    for field in ("columns", "rows"):
        value = as_count(getattr(board, field), f"{owner} {field}", minimum=least, maximum=MAX_SIDE_COUNT)
        object.__setattr__(board, field, value)
    for field in lengths:
        object.__setattr__(board, field, as_length(getattr(board, field), f"{owner} {field}"))
    margin = as_number(board.margin, f"{owner} margin (in squares)", minimum=0.0, error=OptionError)
    if margin > MAX_MARGIN:
        raise OptionError(f"expected {owner} margin (in squares) at most {MAX_MARGIN:g}, got {margin:g}")
    object.__setattr__(board, "margin", margin)


def _pixels_per_square(value):
    return as_count(value, "pixels_per_square", minimum=1, maximum=MAX_PIXELS_PER_SQUARE)


@dataclasses.dataclass(frozen=True)
class Checkerboard:
    """A checkerboard of ``columns x rows`` inner corners.

    Attributes
    ----------
    columns, rows : int
        Inner corners along x and y (squares: one more each).
    square : float
        Side of a square [m].
    margin : float
        White margin around the squares, in squares.
    """

    columns: int = 9
    rows: int = 6
    square: float = 0.025
    margin: float = 1.0

    def __post_init__(self):
        _check_board(self, 2, ("square",))

    @property
    def extent(self):
        """Printed sheet ``(width, height)`` [m]."""
        return ((self.columns + 1 + 2 * self.margin) * self.square, (self.rows + 1 + 2 * self.margin) * self.square)

    def object_points(self):
        """Inner corners in the board frame, row by row from the top left, shape (rows * columns, 3) [m].

        Returns
        -------
        ndarray, shape (rows * columns, 3)
        """
        i, j = np.meshgrid(np.arange(self.columns), np.arange(self.rows))
        x = (i.reshape(-1) - (self.columns - 1) / 2) * self.square
        y = ((self.rows - 1) / 2 - j.reshape(-1)) * self.square
        return np.column_stack([x, y, np.zeros_like(x)])

    def texture(self, pixels_per_square=24):
        """Reflectance image of the printed sheet (1 = white), row 0 at the top.

        Parameters
        ----------
        pixels_per_square : int
            Texture pixels per square (1 to :data:`MAX_PIXELS_PER_SQUARE`).

        Returns
        -------
        ndarray, shape (h, w), float32
        """
        p = _pixels_per_square(pixels_per_square)
        m = int(round(self.margin * p))
        i, j = np.meshgrid(np.arange(self.columns + 1), np.arange(self.rows + 1))
        squares = ((i + j) % 2).astype(np.float32)  # top-left square black
        img = np.kron(squares, np.ones((p, p), np.float32))
        return np.pad(img, m, constant_values=1.0)

    def detect(self, image):
        """Find the inner corners (sub-pixel) in a grey image.

        Parameters
        ----------
        image : ndarray, shape (h, w) or (h, w, 3)
            Grey or BGR image (:func:`~labkit.vision._images.as_gray`).

        Returns
        -------
        object_points : ndarray, shape (k, 3) or None
            Board-frame corners [m] (None: the board was not found).
        image_points : ndarray, shape (k, 2) or None
            Their pixels [px].
        """
        with needs_extra("vision"):
            import cv2
        image = as_gray(image)
        small = cv2.resize(image, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA)
        ok, corners = cv2.findChessboardCorners(small, (self.columns, self.rows),
                                                flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
        if not ok:
            return None, None
        corners = cv2.cornerSubPix(image, (corners * 2 + 0.5).astype(np.float32), (5, 5), (-1, -1),
                                   (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 50, 1e-3))
        return self.object_points(), corners.reshape(-1, 2).astype(float)


@dataclasses.dataclass(frozen=True)
class CharucoBoard:
    """A ChArUco board: a checkerboard with a marker in each white square.

    Attributes
    ----------
    columns, rows : int
        Squares along x and y.
    square : float
        Side of a square [m].
    marker : float
        Side of a marker's black square [m] (< ``square``).
    family : str
        Marker family (an ArUco dictionary; default ``"aruco5x5_100"``).
    margin : float
        White margin around the squares, in squares.
    """

    columns: int = 8
    rows: int = 6
    square: float = 0.03
    marker: float = 0.022
    family: str = "aruco5x5_100"
    margin: float = 0.5

    def __post_init__(self):
        info = family_info(self.family)
        _check_board(self, 3, ("square", "marker"))
        if not self.marker < self.square:
            raise OptionError(f"expected CharucoBoard marker < square, got marker {self.marker:g} m, "
                              f"square {self.square:g} m")
        if self.columns * self.rows // 2 > info.count:
            raise OptionError(f"expected at most {info.count} white squares ({self.family} has {info.count} "
                              f"markers), got {self.columns} x {self.rows} squares")

    @property
    def extent(self):
        """Printed sheet ``(width, height)`` [m]."""
        return ((self.columns + 2 * self.margin) * self.square, (self.rows + 2 * self.margin) * self.square)

    def _cv(self):
        return _charuco(self.columns, self.rows, self.square, self.marker, self.family)

    def texture(self, pixels_per_square=48):
        """Reflectance image of the printed sheet (1 = white), row 0 at the top.

        Parameters
        ----------
        pixels_per_square : int
            Texture pixels per square (up to :data:`MAX_PIXELS_PER_SQUARE`; enough for a pixel per marker bit).

        Raises
        ------
        OptionError
            A count out of range, or too few pixels for OpenCV to draw the markers (the message names one that
            does).

        Returns
        -------
        ndarray, shape (h, w), float32
        """
        with needs_extra("vision"):
            import cv2

        p = _pixels_per_square(pixels_per_square)
        m = int(round(self.margin * p))
        try:
            img = self._cv().generateImage((self.columns * p, self.rows * p), marginSize=0, borderBits=1)
        except cv2.error:  # OpenCV rounds each marker to whole pixels: too few to draw one, or it leaves its square
            raise OptionError(f"expected pixels_per_square enough to draw this board's {self.family} markers "
                              f"({family_info(self.family).bits + 2} bits a side, {self.marker / self.square:.2f} of "
                              f"a square), got {p}; try {_least_drawable(self, p)}") from None
        return np.pad(img.astype(np.float32) / 255.0, m, constant_values=1.0)

    def detect(self, image):
        """Find the ChArUco corners (sub-pixel) in a grey image.

        Parameters
        ----------
        image : ndarray, shape (h, w) or (h, w, 3)
            Grey or BGR image (:func:`~labkit.vision._images.as_gray`).

        Returns
        -------
        object_points : ndarray, shape (k, 3) or None
            Board-frame corners [m] (None: fewer than 6 corners found).
        image_points : ndarray, shape (k, 2) or None
            Their pixels [px].
        """
        with needs_extra("vision"):
            import cv2

        detector = cv2.aruco.CharucoDetector(self._cv())
        corners, ids, _, _ = detector.detectBoard(as_gray(image))
        if ids is None or len(ids) < 6:
            return None, None
        obj, img = self._cv().matchImagePoints(corners, ids)
        obj = obj.reshape(-1, 3).astype(float)
        # OpenCV's board frame: origin at the top-left, y down; labkit's: the centre, y up
        w, h = self.columns * self.square, self.rows * self.square
        obj = np.column_stack([obj[:, 0] - w / 2, h / 2 - obj[:, 1], np.zeros(len(obj))])
        return obj, img.reshape(-1, 2).astype(float)


def _least_drawable(board, p):
    """The first pixels-per-square count above ``p`` at which OpenCV draws ``board`` (``p`` itself: none found)."""
    with needs_extra("vision"):
        import cv2

    for q in range(p + 1, MAX_PIXELS_PER_SQUARE + 1):
        try:
            board._cv().generateImage((board.columns * q, board.rows * q), marginSize=0, borderBits=1)
            return q
        except cv2.error:
            continue
    return p


@functools.lru_cache(maxsize=16)
def _charuco(columns, rows, square, marker, family):
    with needs_extra("vision"):
        import cv2

    return cv2.aruco.CharucoBoard((columns, rows), square, marker, dictionary(family))
