"""Camera calibration from images of a checkerboard or a ChArUco board (:func:`calibrate_camera`).

Intrinsics and distortion come from ``cv2.calibrateCamera`` over every image
where the board was found; the reprojection error is reported overall and per
image, and images whose error stands out (a blurred frame, a board that moved,
a wrong detection) are flagged, and can be dropped with ``drop_flagged``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from labkit.vision._camera import Camera
from labkit.vision._errors import CalibrationImageError
from labkit.vision._markers import _gray

__all__ = ["CameraCalibration", "calibrate_camera", "MIN_IMAGES"]

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
    import cv2

    grays = [_gray(im) for im in images]
    if image_size is None:
        if not grays:
            raise CalibrationImageError(f"expected at least {MIN_IMAGES} images, got none")
        image_size = grays[0].shape[::-1]
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
