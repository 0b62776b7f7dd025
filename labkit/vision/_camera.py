"""The pinhole camera with OpenCV's distortion model (:class:`Camera`) and its text file.

A camera is data: the 3x3 intrinsic matrix ``K`` [px] and the distortion
coefficients in OpenCV's order ``(k1, k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4[, tx, ty]]]])``,
plus the image size the calibration holds for. It is saved as a small TOML file
(``format = "labkit-camera/1"``), kept next to the robot file.

Examples
--------
>>> import numpy as np
>>> cam = Camera.pinhole(1000.0, (1280, 960))
>>> cam.project([[0.0, 0.0, 0.5], [0.05, 0.0, 0.5]])
array([[ 639.5,  479.5],
       [ 739.5,  479.5]])
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from pathlib import Path

import numpy as np

from labkit.exceptions import ShapeError
from labkit.vision._errors import VisionError

__all__ = ["Camera"]

_FORMAT = "labkit-camera/1"
_DISTORTION_LENGTHS = (0, 4, 5, 8, 12, 14)


@dataclasses.dataclass(frozen=True, eq=False)
class Camera:
    """A calibrated camera: pinhole intrinsics plus OpenCV distortion.

    Parameters
    ----------
    matrix : array_like, shape (3, 3)
        Intrinsic matrix ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` [px].
    distortion : array_like, shape (k,)
        Distortion coefficients in OpenCV's order, ``k`` in 0, 4, 5, 8, 12, 14
        (default: none).
    image_size : tuple of int, optional
        ``(width, height)`` [px] of the images the intrinsics hold for.
    name : str
        A label (which camera, which lens, which resolution).

    Raises
    ------
    ShapeError
        ``matrix`` is not 3x3 or ``distortion`` has a length OpenCV does not know.
    VisionError
        Non-positive focal lengths or a last row other than ``(0, 0, 1)``.
    """

    matrix: np.ndarray
    distortion: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(5))
    image_size: tuple | None = None
    name: str = ""

    def __post_init__(self):
        K = np.array(self.matrix, dtype=float)
        if K.shape != (3, 3) or not np.all(np.isfinite(K)):
            raise ShapeError(f"expected a finite 3x3 camera matrix, got shape {K.shape}")
        if not (K[0, 0] > 0 and K[1, 1] > 0) or not np.allclose(K[2], [0, 0, 1]):
            raise VisionError(f"expected fx, fy > 0 and last row (0, 0, 1), got {K.tolist()}")
        D = np.array(self.distortion, dtype=float).reshape(-1)
        if D.size not in _DISTORTION_LENGTHS or not np.all(np.isfinite(D)):
            raise ShapeError(f"expected {_DISTORTION_LENGTHS} finite distortion coefficients, got {D.size}")
        K.flags.writeable = False
        D.flags.writeable = False
        object.__setattr__(self, "matrix", K)
        object.__setattr__(self, "distortion", D)
        if self.image_size is not None:
            w, h = (int(v) for v in self.image_size)
            if w <= 0 or h <= 0:
                raise VisionError(f"expected a positive image size (width, height), got {self.image_size}")
            object.__setattr__(self, "image_size", (w, h))

    @classmethod
    def pinhole(cls, focal, image_size, *, distortion=(), name=""):
        """A camera with square pixels and the principal point at the image centre.

        Parameters
        ----------
        focal : float
            Focal length [px].
        image_size : tuple of int
            ``(width, height)`` [px].
        distortion : array_like, optional
            OpenCV-order distortion coefficients (default none).
        name : str

        Returns
        -------
        Camera
        """
        w, h = image_size
        K = [[focal, 0.0, (w - 1) / 2], [0.0, focal, (h - 1) / 2], [0.0, 0.0, 1.0]]
        return cls(K, np.asarray(distortion, float) if len(distortion) else np.zeros(5), (w, h), name)

    @property
    def focal(self):
        """Focal lengths ``(fx, fy)`` [px]."""
        return float(self.matrix[0, 0]), float(self.matrix[1, 1])

    @property
    def principal_point(self):
        """Principal point ``(cx, cy)`` [px]."""
        return float(self.matrix[0, 2]), float(self.matrix[1, 2])

    def project(self, points, camera_from_points=None):
        """Pixel coordinates of 3-D points (with distortion).

        Parameters
        ----------
        points : array_like, shape (..., 3)
            Points [m], in the camera frame (or in a frame ``camera_from_points`` maps).
        camera_from_points : array_like, shape (4, 4), optional
            Pose of the points' frame in the camera frame [m].

        Returns
        -------
        ndarray, shape (..., 2)
            Pixel coordinates ``(u, v)`` [px] (pixel centres at integers).
        """
        import cv2

        p = np.asarray(points, dtype=float)
        if p.shape[-1:] != (3,):
            raise ShapeError(f"expected points with shape (..., 3), got {p.shape}")
        T = np.eye(4) if camera_from_points is None else np.asarray(camera_from_points, float)
        rvec, _ = cv2.Rodrigues(T[:3, :3])
        uv, _ = cv2.projectPoints(p.reshape(-1, 1, 3), rvec, T[:3, 3], self.matrix, self.distortion)
        return uv.reshape(p.shape[:-1] + (2,))

    def undistort_points(self, pixels):
        """Normalised image coordinates ``(x/z, y/z)`` of pixels (distortion removed).

        Parameters
        ----------
        pixels : array_like, shape (..., 2)
            Pixel coordinates [px].

        Returns
        -------
        ndarray, shape (..., 2)
            Ideal normalised coordinates [1] (rays ``(x, y, 1)`` in the camera frame).
        """
        import cv2

        uv = np.asarray(pixels, dtype=float)
        if uv.shape[-1:] != (2,):
            raise ShapeError(f"expected pixels with shape (..., 2), got {uv.shape}")
        crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-10)
        xy = cv2.undistortPointsIter(uv.reshape(-1, 1, 2), self.matrix, self.distortion, None, None, crit)
        return xy.reshape(uv.shape)

    def field_of_view(self):
        """Horizontal and vertical field of view [rad] (pinhole, without distortion).

        Returns
        -------
        tuple of float
            ``(horizontal, vertical)`` [rad].

        Raises
        ------
        VisionError
            The camera has no image size.
        """
        if self.image_size is None:
            raise VisionError("expected a camera with an image size, got image_size=None")
        w, h = self.image_size
        fx, fy = self.focal
        return 2 * math.atan(w / (2 * fx)), 2 * math.atan(h / (2 * fy))

    @classmethod
    def calibrate(cls, images, board, **options):
        """Calibrate a camera from images of a board (see :func:`labkit.vision.calibrate_camera`).

        Parameters
        ----------
        images : sequence of ndarray
            Images of ``board``.
        board : Checkerboard or CharucoBoard
        **options
            Passed to :func:`labkit.vision.calibrate_camera` (``flags``, ``drop_flagged`` ...).

        Returns
        -------
        CameraCalibration
            ``.camera`` is the calibrated :class:`Camera`; ``.rms`` and ``.per_image`` the errors [px].
        """
        from labkit.vision._calibrate import calibrate_camera

        return calibrate_camera(images, board, **options)

    # -- the text file --------------------------------------------------------
    def save(self, path, **extra):
        """Write the camera as a small TOML file (``format = "labkit-camera/1"``).

        Parameters
        ----------
        path : str or os.PathLike
            File to write (e.g. ``webcam.camera.toml`` next to the robot file).
        **extra
            Numbers or strings recorded in a ``[calibration]`` table (e.g. ``rms_px``).

        Returns
        -------
        pathlib.Path
            The path written.
        """
        path = Path(path)
        lines = [f'format = "{_FORMAT}"', f"name = {_toml_str(self.name)}"]
        if self.image_size is not None:
            lines.append(f"image_size = [{self.image_size[0]}, {self.image_size[1]}]   # width, height [px]")
        lines.append("# intrinsic matrix [px]")
        lines.append("matrix = [")
        lines += [f"    [{', '.join(repr(float(v)) for v in row)}]," for row in self.matrix]
        lines.append("]")
        lines.append("# OpenCV order: k1, k2, p1, p2, k3, ...")
        lines.append(f"distortion = [{', '.join(repr(float(v)) for v in self.distortion)}]")
        if extra:
            lines.append("")
            lines.append("[calibration]")
            for key, value in extra.items():
                lines.append(f"{key} = {_toml_str(value) if isinstance(value, str) else repr(float(value))}")
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        return path

    @classmethod
    def load(cls, path):
        """Read a camera file written by :meth:`save`.

        Parameters
        ----------
        path : str or os.PathLike

        Returns
        -------
        Camera

        Raises
        ------
        VisionError
            The file is not a ``labkit-camera/1`` file or lacks ``matrix``.
        """
        path = Path(path)
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except (OSError, tomllib.TOMLDecodeError) as exc:
            raise VisionError(f"expected a readable TOML camera file, got {path}: {exc}") from exc
        if data.get("format") != _FORMAT or "matrix" not in data:
            raise VisionError(f"expected format = {_FORMAT!r} and a matrix in {path}, got format = "
                              f"{data.get('format')!r} and keys {sorted(data)}")
        return cls(data["matrix"], data.get("distortion", np.zeros(5)), data.get("image_size"), data.get("name", ""))

    def __repr__(self):
        fx, fy = self.focal
        cx, cy = self.principal_point
        return (f"Camera(fx={fx:.2f}, fy={fy:.2f}, cx={cx:.2f}, cy={cy:.2f}, "
                f"distortion={np.round(self.distortion, 5).tolist()}, image_size={self.image_size})")


def _toml_str(text):
    return '"' + str(text).replace("\\", "\\\\").replace('"', '\\"') + '"'
