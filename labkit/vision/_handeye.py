"""Camera-to-robot (hand-eye) calibration: :func:`hand_eye`.

Two set-ups:

* ``"eye_to_hand"``: the camera is fixed, a marker is on the gripper. Unknowns:
  ``base_from_camera`` and ``tool_from_marker``;
  ``base_from_tool[i] @ tool_from_marker = base_from_camera @ camera_from_marker[i]``.
* ``"eye_in_hand"``: the camera is on the gripper, a marker is fixed in the world. Unknowns:
  ``tool_from_camera`` and ``base_from_marker``;
  ``base_from_tool[i] @ tool_from_camera @ camera_from_marker[i] = base_from_marker``.

OpenCV's solvers (``cv2.calibrateHandEye``, Park's method by default, or
``cv2.calibrateRobotWorldHandEye``, Shah's or Li's) give the start,
a least-squares fit over both unknowns refines it, and every view gets its
residual and a leave-one-out error (the view's marker position predicted by a
fit without it). Views are paired **by pose id**, never by position in a list,
so a missed detection drops its view instead of shifting all that follow. A
:class:`HandEyeWarning` says when the tool orientations are too alike (the
translation is then poorly determined: 15 views within +-0.35 rad gave 72 mm).
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from labkit.exceptions import ShapeError, needs_extra
from labkit.exceptions import HandEyeWarning, VisionError
from labkit.rotations import check_rotation, is_rotation
from labkit.validation import as_batch, as_number, as_option

__all__ = ["HandEyeResult", "hand_eye", "rotation_spread", "SETUPS", "STARTS", "MIN_ROTATION_SPREAD"]

SETUPS = ("eye_to_hand", "eye_in_hand")
#: starting solvers (``hand_eye(start=...)``): OpenCV's hand-eye methods (``cv2.calibrateHandEye``)
#: and its robot-world/hand-eye methods (``cv2.calibrateRobotWorldHandEye``, both unknowns at once)
STARTS = {"park": ("hand_eye", "CALIB_HAND_EYE_PARK"), "tsai": ("hand_eye", "CALIB_HAND_EYE_TSAI"),
           "horaud": ("hand_eye", "CALIB_HAND_EYE_HORAUD"), "andreff": ("hand_eye", "CALIB_HAND_EYE_ANDREFF"),
           "daniilidis": ("hand_eye", "CALIB_HAND_EYE_DANIILIDIS"),
           "shah": ("robot_world", "CALIB_ROBOT_WORLD_HAND_EYE_SHAH"),
           "li": ("robot_world", "CALIB_ROBOT_WORLD_HAND_EYE_LI")}
#: the second principal spread of the tool orientations below which hand_eye warns [rad]
MIN_ROTATION_SPREAD = 0.3
#: how far from orthonormal a pose's rotation part may be (a pose read from a file with few digits)
ROTATION_TOL = 1e-3
_ANGLE_SCALE = 0.1  # m per rad: weighs rotation residuals against position residuals


def _rotvec(R):
    with needs_extra("vision"):
        import cv2

    return cv2.Rodrigues(np.asarray(R, float))[0].reshape(3)


def _matrix(x):
    with needs_extra("vision"):
        import cv2

    T = np.eye(4)
    T[:3, :3] = cv2.Rodrigues(np.asarray(x[:3], float))[0]
    T[:3, 3] = x[3:6]
    return T


def _params(T):
    return np.concatenate([_rotvec(T[:3, :3]), T[:3, 3]])


def rotation_spread(base_from_tool):
    """Principal spreads of a set of tool orientations [rad], largest first.

    The rotation vectors of every orientation relative to their mean, their RMS
    along the three principal directions. A hand-eye calibration needs rotations
    about at least two different axes: the second value is the one that matters.

    Parameters
    ----------
    base_from_tool : array_like, shape (n, 4, 4)

    Returns
    -------
    ndarray, shape (3,)
        [rad]

    Raises
    ------
    ShapeError
        Not a non-empty (n, 4, 4) array of finite numbers.
    RotationMatrixError
        A rotation part that is not a rotation (within :data:`ROTATION_TOL`).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> T = np.tile(np.eye(4), (3, 1, 1))
    >>> T[:, :3, :3] = Rotation.from_rotvec([[0.5, 0, 0], [-0.5, 0, 0], [0, 0, 0]]).as_matrix()
    >>> np.round(rotation_spread(T), 3)
    array([0.408, 0.   , 0.   ])
    """
    from scipy.spatial.transform import Rotation

    T = as_batch(base_from_tool, (4, 4), "base_from_tool")
    if T.ndim != 3 or len(T) == 0:
        raise ShapeError(f"expected base_from_tool with shape (n, 4, 4), n >= 1, got {T.shape}")
    R = Rotation.from_matrix(check_rotation(T[:, :3, :3], tol=ROTATION_TOL))
    mean = R.mean()
    v = (mean.inv() * R).as_rotvec()
    return np.linalg.svd(v, compute_uv=False) / np.sqrt(len(v))


@dataclasses.dataclass(frozen=True, eq=False)
class HandEyeResult:
    """Result of :func:`hand_eye`.

    Attributes
    ----------
    setup : {"eye_to_hand", "eye_in_hand"}
    camera_pose : ndarray, shape (4, 4)
        ``base_from_camera`` (eye to hand) or ``tool_from_camera`` (eye in hand) [m].
    marker_pose : ndarray, shape (4, 4)
        ``tool_from_marker`` (eye to hand) or ``base_from_marker`` (eye in hand) [m].
    pose_ids : list of str
        The views used, in order.
    position_residual : ndarray, shape (n,)
        Distance between the measured and the fitted marker position per view [m].
    angle_residual : ndarray, shape (n,)
        Angle between the measured and the fitted marker orientation per view [rad].
    loo_position : ndarray, shape (n,)
        Leave-one-out: the view's marker position error under a fit without it [m].
    rotation_spread : ndarray, shape (3,)
        :func:`rotation_spread` of the views [rad].
    dropped : list of str
        Pose ids that had a robot pose but no detection, or the reverse.
    """

    setup: str
    camera_pose: np.ndarray
    marker_pose: np.ndarray
    pose_ids: list
    position_residual: np.ndarray
    angle_residual: np.ndarray
    loo_position: np.ndarray
    rotation_spread: np.ndarray
    dropped: list

    def to_dataframe(self):
        """One row per view: residuals and leave-one-out error [mm, deg].

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        return pd.DataFrame({"residual [mm]": self.position_residual * 1e3,
                             "residual [deg]": np.degrees(self.angle_residual),
                             "leave-one-out [mm]": self.loo_position * 1e3}, index=pd.Index(self.pose_ids, name="pose_id"))


def _as_mapping(poses, name):
    if isinstance(poses, dict):
        out = {str(k): as_batch(v, (4, 4), f"{name}[{k!r}]", batch=False) for k, v in poses.items()}
    else:
        arr = as_batch(poses, (4, 4), name)
        if arr.ndim != 3:
            raise ShapeError(f"expected {name} as {{pose_id: 4x4}} or shape (n, 4, 4), got shape {arr.shape}")
        out = {str(k): T for k, T in enumerate(arr)}
    for k, T in out.items():
        check_rotation(T[:3, :3], tol=ROTATION_TOL)
    return out


def _predict(setup, X, Y, A):
    """camera_from_marker predicted for robot poses A (n, 4, 4)."""
    Xi = np.linalg.inv(X)
    if setup == "eye_to_hand":
        return Xi @ A @ Y
    return Xi @ np.linalg.inv(A) @ Y


def _refine(setup, X, Y, A, B):
    from scipy.optimize import least_squares

    def residuals(x):
        P = _predict(setup, _matrix(x[:6]), _matrix(x[6:]), A)
        dp = (P[:, :3, 3] - B[:, :3, 3]).reshape(-1)
        dr = np.array([_rotvec(p[:3, :3].T @ b[:3, :3]) for p, b in zip(P, B)]).reshape(-1) * _ANGLE_SCALE
        return np.concatenate([dp, dr])

    sol = least_squares(residuals, np.concatenate([_params(X), _params(Y)]), method="lm", xtol=1e-12, ftol=1e-12)
    return _matrix(sol.x[:6]), _matrix(sol.x[6:])


def _start(setup, start, A, B):
    """OpenCV's closed-form start: (X, Y) = (camera pose, marker pose) of the setup."""
    with needs_extra("vision"):
        import cv2

    from scipy.spatial.transform import Rotation

    family, flag = STARTS[start]
    tool_from_base = np.linalg.inv(A)
    if family == "robot_world":
        # OpenCV: world2cam @ base2world = gripper2cam @ base2gripper
        world2cam = np.linalg.inv(B) if setup == "eye_to_hand" else B
        R_bw, t_bw, R_gc, t_gc = cv2.calibrateRobotWorldHandEye(
            world2cam[:, :3, :3], world2cam[:, :3, 3], tool_from_base[:, :3, :3], tool_from_base[:, :3, 3],
            method=getattr(cv2, flag))
        base2world, gripper2cam = np.eye(4), np.eye(4)
        base2world[:3, :3], base2world[:3, 3] = R_bw, np.asarray(t_bw).reshape(3)
        gripper2cam[:3, :3], gripper2cam[:3, 3] = R_gc, np.asarray(t_gc).reshape(3)
        return np.linalg.inv(base2world if setup == "eye_to_hand" else gripper2cam), \
            np.linalg.inv(gripper2cam if setup == "eye_to_hand" else base2world)
    robot_side = tool_from_base if setup == "eye_to_hand" else A
    R, t = cv2.calibrateHandEye(robot_side[:, :3, :3], robot_side[:, :3, 3], B[:, :3, :3], B[:, :3, 3],
                                method=getattr(cv2, flag))
    if not is_rotation(np.asarray(R, float), tol=ROTATION_TOL):
        raise VisionError(f"expected views of one rigid {setup} setup, got views OpenCV's {start!r} start finds no "
                          f"rotation for (the other setup? views paired with the wrong pose ids, a marker that moved?)")
    X = np.eye(4)
    X[:3, :3], X[:3, 3] = R, np.asarray(t).reshape(3)
    # the other unknown from every view, averaged
    Ys = tool_from_base @ X @ B if setup == "eye_to_hand" else A @ X @ B
    Y = np.eye(4)
    Y[:3, :3] = Rotation.from_matrix(Ys[:, :3, :3]).mean().as_matrix()
    Y[:3, 3] = Ys[:, :3, 3].mean(axis=0)
    return X, Y


def hand_eye(base_from_tool, camera_from_marker, *, setup="eye_to_hand", start="park",
             min_spread=MIN_ROTATION_SPREAD, leave_one_out=True):
    """Camera-to-robot calibration from paired robot poses and marker detections.

    Parameters
    ----------
    base_from_tool : mapping or array_like, shape (n, 4, 4)
        ``{pose_id: base_from_tool}``: the robot's tool poses (its FK of the sensed or
        commanded joints) [m]. Arrays are paired by index.
    camera_from_marker : mapping or array_like, shape (m, 4, 4)
        ``{pose_id: camera_from_marker}``: the marker poses measured at the same pose ids
        (:attr:`MarkerDetection.pose`) [m]. Pose ids missing on either side are dropped.
    setup : {"eye_to_hand", "eye_in_hand"}
    start : str
        The starting solver, a key of :data:`STARTS` (``"park"``; ``"shah"`` and ``"li"`` solve
        both unknowns at once); the least-squares fit that follows is the same for all.
    min_spread : float
        Warn (:class:`HandEyeWarning`) when the second principal spread of the tool
        orientations is below this [rad].
    leave_one_out : bool
        Compute the leave-one-out errors (n extra fits).

    Returns
    -------
    HandEyeResult

    Raises
    ------
    OptionError
        Unknown setup or start.
    ShapeError
        A pose that is not a finite 4x4 transform, a ``min_spread`` that is not a finite number in 0..pi.
    RotationMatrixError
        A pose whose rotation part is not a rotation (within :data:`ROTATION_TOL`).
    VisionError
        Fewer than 3 paired views, or views that fit no rigid setup (the start finds no rotation).

    Warns
    -----
    HandEyeWarning
        The views' orientations are too alike.
    """
    setup = as_option(setup, SETUPS, "setup")
    start = as_option(start, STARTS, "start")
    min_spread = as_number(min_spread, "min_spread", unit="rad", minimum=0.0)
    if min_spread > np.pi:
        raise ShapeError(f"expected min_spread at most pi rad (no spread of rotations is larger), got {min_spread:g}")
    robot = _as_mapping(base_from_tool, "base_from_tool")
    seen = _as_mapping(camera_from_marker, "camera_from_marker")
    ids = [k for k in robot if k in seen]
    dropped = [k for k in robot if k not in seen] + [k for k in seen if k not in robot]
    if len(ids) < 3:
        raise VisionError(f"expected at least 3 views paired by pose id, got {len(ids)} (dropped {dropped})")
    A = np.array([robot[k] for k in ids])
    B = np.array([seen[k] for k in ids])
    spread = rotation_spread(A)
    if spread[1] < min_spread:
        warnings.warn(f"the tool orientations are too alike for a hand-eye calibration: spread "
                      f"{np.degrees(spread[0]):.0f} / {np.degrees(spread[1]):.0f} deg about the two main axes, expected "
                      f"at least {np.degrees(min_spread):.0f} deg about two different axes; tilt the gripper "
                      "more between the views", HandEyeWarning, stacklevel=2)
    X, Y = _start(setup, start, A, B)
    X, Y = _refine(setup, X, Y, A, B)
    P = _predict(setup, X, Y, A)
    pos = np.linalg.norm(P[:, :3, 3] - B[:, :3, 3], axis=1)
    ang = np.array([np.linalg.norm(_rotvec(p[:3, :3].T @ b[:3, :3])) for p, b in zip(P, B)])
    loo = np.full(len(ids), np.nan)
    if leave_one_out and len(ids) > 3:
        for i in range(len(ids)):
            keep = np.arange(len(ids)) != i
            Xi, Yi = _refine(setup, X, Y, A[keep], B[keep])
            loo[i] = float(np.linalg.norm(_predict(setup, Xi, Yi, A[i:i + 1])[0, :3, 3] - B[i, :3, 3]))
    return HandEyeResult(setup, X, Y, ids, pos, ang, loo, spread, dropped)
