"""The pinhole camera with OpenCV's distortion model (:class:`Camera`), its text file, and its
calibration from images of a checkerboard or a ChArUco board (:func:`calibrate_camera`: intrinsics
and distortion by ``cv2.calibrateCamera``, the reprojection error overall and per image, and
images whose error stands out flagged and dropped).

A camera is data: the 3x3 intrinsic matrix ``K`` [px] and the distortion
coefficients in OpenCV's order ``(k1, k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4[, tx, ty]]]])``,
plus the image size the calibration holds for. It is saved as a small TOML file
(``format = "labkit-camera/1"``), kept next to the robot file.

Examples
--------
>>> import numpy as np
>>> cam = Camera.pinhole(1000.0, (1280, 960))
>>> cam.project([[0.0, 0.0, 0.5], [0.05, 0.0, 0.5]]).tolist()
[[639.5, 479.5], [739.5, 479.5]]
"""

from __future__ import annotations

import dataclasses
import math
import tomllib

import numpy as np

from labkit.exceptions import ShapeError, needs_extra
from labkit.exceptions import CalibrationImageError, VisionError
from labkit.validation import as_batch, as_number, as_path
from labkit.vision._images import as_gray, image_size as _checked_size

__all__ = ["Camera", "CameraCalibration", "calibrate_camera", "MIN_IMAGES"]

_FORMAT = "labkit-camera/1"
_DISTORTION_LENGTHS = (0, 4, 5, 8, 12, 14)
#: the largest distortion coefficient taken (fitted lenses stay far below: wide-angle rational models reach tens)
MAX_DISTORTION = 1e4


def _numbers(value, what):
    """``value`` as a float array, or a ShapeError saying what was expected and what was received."""
    try:
        return np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"expected the {what} as numbers, got {value!r} ({exc})") from None


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
        K = _numbers(self.matrix, "camera matrix")
        if K.shape != (3, 3) or not np.all(np.isfinite(K)):
            raise ShapeError(f"expected a finite 3x3 camera matrix, got shape {K.shape}")
        if not (K[0, 0] > 0 and K[1, 1] > 0) or not np.allclose(K[2], [0, 0, 1]) or K[0, 1] != 0 or K[1, 0] != 0:
            raise VisionError(f"expected a camera matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0 "
                              f"(no skew: OpenCV's projection ignores it), got {K.tolist()}")
        D = _numbers(self.distortion, "distortion coefficients").reshape(-1)
        if D.size not in _DISTORTION_LENGTHS or not np.all(np.isfinite(D)):
            raise ShapeError(f"expected {_DISTORTION_LENGTHS} finite distortion coefficients, got {D.size}")
        if np.any(np.abs(D) > MAX_DISTORTION):
            raise VisionError(f"expected distortion coefficients within +-{MAX_DISTORTION:g}, got {D.tolist()}")
        if not isinstance(self.name, str):
            raise VisionError(f"expected the camera's name as text, got {self.name!r}")
        K.flags.writeable = False
        D.flags.writeable = False
        object.__setattr__(self, "matrix", K)
        object.__setattr__(self, "distortion", D)
        if self.image_size is not None:
            object.__setattr__(self, "image_size", _checked_size(self.image_size))

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
        w, h = _checked_size(image_size)
        focal = as_number(focal, "focal", unit="px", positive=True)
        K = [[focal, 0.0, (w - 1) / 2], [0.0, focal, (h - 1) / 2], [0.0, 0.0, 1.0]]
        D = _numbers(distortion, "distortion coefficients").reshape(-1)
        return cls(K, D if D.size else np.zeros(5), (w, h), name)

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
        with needs_extra("vision"):
            import cv2

        p = as_batch(points, (3,), "points")
        T = np.eye(4) if camera_from_points is None else as_batch(camera_from_points, (4, 4), "camera_from_points",
                                                                     batch=False)
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
        with needs_extra("vision"):
            import cv2

        uv = as_batch(pixels, (2,), "pixels")
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

        Raises
        ------
        VisionError
            A path that is not one, a key that is not a name, a value that is neither text nor a finite number.
        """
        path = as_path(path, "the camera file to write", error=VisionError)
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
                if not key.isidentifier():
                    raise VisionError(f"expected [calibration] keys as names (letters, digits, _), got {key!r}")
                if not isinstance(value, str):
                    value = as_number(value, f"[calibration] {key}", error=VisionError)
                lines.append(f"{key} = {_toml_str(value) if isinstance(value, str) else repr(value)}")
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
        path = as_path(path, "the camera file", error=VisionError)
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
            raise VisionError(f"expected a readable UTF-8 TOML camera file, got {path}: {exc}") from None
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


#: fewest images with the board found that a calibration accepts
MIN_IMAGES = 5


@dataclasses.dataclass(frozen=True, eq=False)
class CameraCalibration:
    """Result of a camera calibration.

    Attributes
    ----------
    camera : Camera
    rms : float
        RMS reprojection error over every used corner [px].
    per_image : ndarray, shape (n_images,)
        RMS reprojection error of each image [px] (NaN where the board was not found).
    found : ndarray of bool, shape (n_images,)
        The board was found in the image.
    flagged : ndarray of bool, shape (n_images,)
        The image's error exceeds ``max(flag_factor * median, flag_floor)``.
    used : ndarray of bool, shape (n_images,)
        The image entered the final fit.
    board_poses : ndarray, shape (n_images, 4, 4)
        ``camera_from_board`` of each image [m] (NaN where not found).
    """

    camera: Camera
    rms: float
    per_image: np.ndarray
    found: np.ndarray
    flagged: np.ndarray
    used: np.ndarray
    board_poses: np.ndarray

    def to_dataframe(self):
        """One row per image: found, used, flagged, RMS error [px].

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        return pd.DataFrame({"found": self.found, "used": self.used, "flagged": self.flagged,
                             "rms_px": self.per_image})


def _fit(obj, img, size, flags):
    with needs_extra("vision"):
        import cv2

    rms, K, D, rvecs, tvecs = cv2.calibrateCamera([o.astype(np.float32) for o in obj],
                                                  [i.astype(np.float32) for i in img], size, None, None, flags=flags)
    per = []
    for o, i, r, t in zip(obj, img, rvecs, tvecs):
        uv, _ = cv2.projectPoints(o, r, t, K, D)
        per.append(float(np.sqrt(np.mean(np.sum((uv.reshape(-1, 2) - i) ** 2, axis=1)))))
    return float(rms), K, D, rvecs, tvecs, np.array(per)


def calibrate_camera(images, board, *, image_size=None, flags=0, flag_factor=2.5, flag_floor=0.2,
                     drop_flagged=True, name=""):
    """Intrinsics and distortion from images of a calibration board.

    Parameters
    ----------
    images : sequence of ndarray
        Grey or BGR images of ``board`` (15-30 views, tilted up to 45 deg, covering the image).
    board : Checkerboard or CharucoBoard
    image_size : tuple of int, optional
        ``(width, height)`` [px]; default the first image's.
    flags : int
        ``cv2.calibrateCamera`` flags (e.g. ``cv2.CALIB_FIX_K3``).
    flag_factor, flag_floor : float
        An image is flagged when its RMS error exceeds ``max(flag_factor * median, flag_floor)`` [px].
    drop_flagged : bool
        Fit again without the flagged images.
    name : str
        Label of the camera.

    Returns
    -------
    CameraCalibration

    Raises
    ------
    CalibrationImageError
        The board was found in fewer than :data:`MIN_IMAGES` images.
    """
    with needs_extra("vision"):
        import cv2

    if isinstance(images, np.ndarray) and images.ndim == 2 or not hasattr(images, "__iter__"):
        raise VisionError(f"expected a sequence of images, got {type(images).__name__}")
    grays = [as_gray(im) for im in images]
    if image_size is None:
        if not grays:
            raise CalibrationImageError(f"expected at least {MIN_IMAGES} images, got none")
        image_size = grays[0].shape[::-1]
    image_size = _checked_size(image_size)
    obj, img, index = [], [], []
    for k, g in enumerate(grays):
        o, i = board.detect(g)
        if o is not None:
            obj.append(o)
            img.append(i)
            index.append(k)
    found = np.zeros(len(grays), dtype=bool)
    found[index] = True
    if len(index) < MIN_IMAGES:
        raise CalibrationImageError(f"expected the board in at least {MIN_IMAGES} images, found it in {len(index)} "
                                    f"of {len(grays)} (check the board's size in squares and that it is fully in view)")
    rms, K, D, rvecs, tvecs, per = _fit(obj, img, tuple(image_size), flags)
    limit = max(flag_factor * float(np.median(per)), flag_floor)
    bad = per > limit
    keep = ~bad if drop_flagged and bad.any() and (~bad).sum() >= MIN_IMAGES else np.ones(len(per), bool)
    if not keep.all():
        rms, K, D, rvecs_k, tvecs_k, _ = _fit([o for o, k in zip(obj, keep) if k], [i for i, k in zip(img, keep) if k],
                                             tuple(image_size), flags)
        # every image's pose and error under the final intrinsics
        rvecs, tvecs, per = [], [], []
        for o, i in zip(obj, img):
            _, r, t = cv2.solvePnP(o, i, K, D)
            uv, _ = cv2.projectPoints(o, r, t, K, D)
            rvecs.append(r)
            tvecs.append(t)
            per.append(float(np.sqrt(np.mean(np.sum((uv.reshape(-1, 2) - i) ** 2, axis=1)))))
        per = np.array(per)
    per_image = np.full(len(grays), np.nan)
    per_image[index] = per
    flagged = np.zeros(len(grays), bool)
    flagged[index] = bad
    used = np.zeros(len(grays), bool)
    used[index] = keep
    poses = np.full((len(grays), 4, 4), np.nan)
    for k, r, t in zip(index, rvecs, tvecs):
        poses[k] = np.eye(4)
        poses[k, :3, :3] = cv2.Rodrigues(r)[0]
        poses[k, :3, 3] = np.asarray(t).reshape(3)
    camera = Camera(K, D.reshape(-1), tuple(int(v) for v in image_size), name)
    return CameraCalibration(camera, rms, per_image, found, flagged, used, poses)
