"""Where the camera is: its pose in the base frame from reference markers fixed to the base.

Reference markers (a printed sheet fixed to the robot's base at known poses)
give the camera's pose without the arm: one PnP over every corner of every
reference marker of every frame (:func:`locate_camera`). Unlike a hand-eye
calibration that uses the arm's own forward kinematics, it does not absorb
the arm's errors, so the camera can then check the arm.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from labkit.exceptions import MarkerNotFoundError, needs_extra
from labkit.vision._markers import DEFAULT_CORNER_SIGMA, marker_corners

__all__ = ["CameraLocation", "locate_camera", "transform_covariance"]


@dataclasses.dataclass(frozen=True, eq=False)
class CameraLocation:
    """The camera's pose in the base frame, with its uncertainty.

    Attributes
    ----------
    base_from_camera : ndarray, shape (4, 4)
        Pose of the camera in the base frame [m].
    covariance : ndarray, shape (6, 6)
        Covariance of ``camera_from_base`` as (rotation vector [rad], translation [m]).
    reprojection_error : float
        RMS corner reprojection error [px].
    n_corners : int
        Corners used (4 per reference marker and frame).
    """

    base_from_camera: np.ndarray
    covariance: np.ndarray
    reprojection_error: float
    n_corners: int

    def to_base(self, point, covariance=None):
        """A point from the camera frame to the base frame, with its covariance.

        Parameters
        ----------
        point : array_like, shape (3,)
            Point in the camera frame [m].
        covariance : array_like, shape (3, 3), optional
            Its covariance in the camera frame [m^2].

        Returns
        -------
        position : ndarray, shape (3,)
            The point in the base frame [m].
        covariance : ndarray, shape (3, 3)
            Its covariance in the base frame [m^2]: the point's own plus the camera location's.
        """
        p = np.asarray(point, dtype=float).reshape(3)
        R = self.base_from_camera[:3, :3]
        cov = np.zeros((3, 3)) if covariance is None else R @ np.asarray(covariance, float) @ R.T
        return R @ p + self.base_from_camera[:3, 3], cov + transform_covariance(
            np.linalg.inv(self.base_from_camera), self.covariance, p, inverse=True)


def transform_covariance(T, covariance, point, *, inverse=False):
    """Covariance of ``T @ point`` (or ``inv(T) @ point``) from the covariance of ``T``'s parameters.

    Parameters
    ----------
    T : array_like, shape (4, 4)
        A rigid transform.
    covariance : array_like, shape (6, 6)
        Covariance of its (rotation vector [rad], translation [m]).
    point : array_like, shape (3,)
        The point [m].
    inverse : bool
        Propagate through ``inv(T)`` instead of ``T``.

    Returns
    -------
    ndarray, shape (3, 3)
        Covariance of the mapped point [m^2].
    """
    with needs_extra("vision"):
        import cv2

    T = np.asarray(T, dtype=float)
    p = np.asarray(point, dtype=float).reshape(3)
    rvec = cv2.Rodrigues(T[:3, :3])[0].reshape(3)
    tvec = T[:3, 3]

    def mapped(x):
        R = cv2.Rodrigues(x[:3])[0]
        return R.T @ (p - x[3:]) if inverse else R @ p + x[3:]

    x0 = np.concatenate([rvec, tvec])
    jac = np.zeros((3, 6))
    for k in range(6):
        dx = np.zeros(6)
        dx[k] = 1e-6
        jac[:, k] = (mapped(x0 + dx) - mapped(x0 - dx)) / 2e-6
    return jac @ np.asarray(covariance, float) @ jac.T


def locate_camera(detections, base_markers, camera, *, corner_sigma=DEFAULT_CORNER_SIGMA):
    """The camera's pose in the base frame from reference markers seen in one or more frames.

    Parameters
    ----------
    detections : sequence of MarkerDetection, or sequence of sequences of them
        Detections of one frame, or of several frames of the same (fixed) camera.
    base_markers : mapping
        ``{id: base_from_marker}``: poses of the reference markers in the base frame [m].
    camera : Camera
    corner_sigma : float
        A-priori corner noise [px] (the covariance uses the larger of it and the RMS error).

    Returns
    -------
    CameraLocation

    Raises
    ------
    MarkerNotFoundError
        No reference marker among the detections.
    """
    with needs_extra("vision"):
        import cv2

    frames = detections if detections and not hasattr(detections[0], "id") else [detections]
    obj, img = [], []
    for frame in frames:
        for d in frame:
            if d.id in base_markers:
                T = np.asarray(base_markers[d.id], dtype=float)
                obj.append(marker_corners(d.size) @ T[:3, :3].T + T[:3, 3])
                img.append(d.corners)
    if not obj:
        seen = sorted({d.id for frame in frames for d in frame})
        raise MarkerNotFoundError(f"expected reference marker(s) {sorted(base_markers)} in view, found id(s) {seen}")
    obj = np.concatenate(obj)
    img = np.concatenate(img)
    ok, rvec, tvec = cv2.solvePnP(obj, img, camera.matrix, camera.distortion, flags=cv2.SOLVEPNP_SQPNP)
    rvec, tvec = cv2.solvePnPRefineLM(obj, img, camera.matrix, camera.distortion, rvec, tvec)
    uv, jac = cv2.projectPoints(obj, rvec, tvec, camera.matrix, camera.distortion)
    err = float(np.sqrt(np.mean(np.sum((uv.reshape(-1, 2) - img) ** 2, axis=1))))
    J = jac[:, :6]
    sigma = max(corner_sigma, err)
    cov = sigma ** 2 * np.linalg.pinv(J.T @ J)
    camera_from_base = np.eye(4)
    camera_from_base[:3, :3] = cv2.Rodrigues(rvec)[0]
    camera_from_base[:3, 3] = tvec.reshape(3)
    return CameraLocation(np.linalg.inv(camera_from_base), cov, err, len(obj))
