"""Marker detection and pose: :func:`marker_poses`.

Markers are found with OpenCV's ArUco detector (AprilTag 36h11 and ArUco
dictionaries, :data:`labkit.vision.FAMILIES`), their corners refined to
sub-pixel precision, and each marker's pose solved with IPPE for squares
(``cv2.SOLVEPNP_IPPE_SQUARE``), which returns the two poses a square can
have. When the second one reprojects nearly as well as the first, the tilt of
the marker is unknown (it is seen too face-on, too small or too blurred): that
is reported as an ambiguous pose rather than guessed.

Each detection carries a covariance of its pose from the corner noise
(``sigma^2 (J^T W J)^-1``, J the Jacobian of the corners' reprojection, W per
corner ``N^T N`` of the unit normals of its two edges: a sharp corner of a marker
seen obliquely is the crossing of two nearly parallel edges), so a position
comes with its uncertainty.

Coordinates: the marker frame has its origin at the centre of the black square,
x to the right, y up (towards the top of the printed marker), z out of the
printed face (towards a camera that sees it); the camera frame is OpenCV's
(x right, y down, z along the optical axis). Units: m, rad, px.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from labkit.exceptions import OptionError, ShapeError, needs_extra
from labkit.exceptions import AmbiguousPoseError, MarkerNotFoundError, WrongMarkerError
from labkit.validation import as_count, as_number, as_option
from labkit.vision._camera import Camera
from labkit.vision._families import as_length, dictionary, family_info
from labkit.vision._images import as_gray as _gray

__all__ = ["MarkerDetection", "marker_poses", "detect_markers", "marker_corners", "marker_size", "quad_bit_width",
           "DEFAULT_CORNER_SIGMA", "AMBIGUITY_RATIO", "MIN_BIT_WIDTH"]

#: a-priori standard deviation of a refined corner [px] (the floor of the noise model)
DEFAULT_CORNER_SIGMA = 0.15
#: a pose is ambiguous when the second IPPE solution's reprojection error is below this many times the first's
AMBIGUITY_RATIO = 3.0
_ON_AMBIGUOUS = ("raise", "keep")
_PROFILE_SAMPLES = 25
#: images with a side this long [px] or longer are searched at half resolution first
_DOWNSCALE_ABOVE = 1000
_EDGE_FRACTIONS = np.linspace(0.12, 0.88, 24)
#: an edge profile reaches this fraction of a bit into the black border, and at least _MIN_HALF_PROFILE px
_PROFILE_BIT_FRACTION, _MIN_HALF_PROFILE = 0.45, 1.5
#: below this bit width across a side [px] the shortest profile reaches more than two thirds of the way across
#: the black border, within a blur's width of the data bits (corners 2 px off at 2.1 px, 0.07 px at 2.5 px):
#: a marker seen this obliquely is not used for a measurement
MIN_BIT_WIDTH = _MIN_HALF_PROFILE / (2.0 / 3.0)


def marker_corners(size):
    """Corners of a square marker in its own frame (OpenCV's order), shape (4, 3) [m].

    Parameters
    ----------
    size : float
        Side of the black square [m].

    Returns
    -------
    ndarray, shape (4, 3)
        Top-left, top-right, bottom-right, bottom-left (x right, y up, z = 0).

    Examples
    --------
    >>> marker_corners(0.04)[0]
    array([-0.02,  0.02,  0.  ])
    """
    s = as_length(size, "size (the black square)") / 2
    return np.array([[-s, s, 0.0], [s, s, 0.0], [s, -s, 0.0], [-s, -s, 0.0]])


def marker_size(size, marker_id):
    """The side of marker ``marker_id``'s black square [m]: ``size`` itself or its entry ``{id: size}``.

    Parameters
    ----------
    size : float or dict of int to float
        Side of every marker's black square, or of each one's [m].
    marker_id : int or None
        The marker (``None``: ``size`` must be one number).

    Returns
    -------
    float

    Raises
    ------
    OptionError
        A size that is not a positive finite number, or a mapping without that marker.
    """
    if isinstance(size, dict):
        if marker_id not in size:
            raise OptionError(f"expected a size for marker {marker_id} in {size!r}")
        return as_length(size[marker_id], f"the size of marker {marker_id}")
    return as_length(size, "size")


@dataclasses.dataclass(frozen=True, eq=False)
class MarkerDetection:
    """One marker seen in one image, with its pose and the uncertainty of that pose.

    Attributes
    ----------
    id : int
        Marker id within its family.
    pose : ndarray, shape (4, 4)
        ``camera_from_marker``: the marker's pose in the camera frame [m].
    corners : ndarray, shape (4, 2)
        Sub-pixel image corners [px] (OpenCV's order, see :func:`marker_corners`).
    covariance : ndarray, shape (6, 6)
        Covariance of ``(rotation vector [rad], translation [m])`` of the pose.
    reprojection_error : float
        RMS corner reprojection error of the chosen pose [px].
    alternative_error : float
        The same for the other IPPE solution [px] (``inf`` if there was none).
    ambiguous : bool
        The two solutions fit nearly equally (``alternative_error < AMBIGUITY_RATIO * max(error, sigma)``).
    size : float
        Side of the black square [m].
    family : str
    """

    id: int
    pose: np.ndarray
    corners: np.ndarray
    covariance: np.ndarray
    reprojection_error: float
    alternative_error: float
    ambiguous: bool
    size: float
    family: str

    @property
    def position(self):
        """Centre of the marker in the camera frame, shape (3,) [m]."""
        return self.pose[:3, 3].copy()

    @property
    def uncertainty(self):
        """Standard uncertainty of :attr:`position` along the camera axes, shape (3,) [m]."""
        return np.sqrt(np.diag(self.covariance)[3:])

    @property
    def distance(self):
        """Distance from the camera centre to the marker centre [m]."""
        return float(np.linalg.norm(self.pose[:3, 3]))

    @property
    def tilt(self):
        """Angle between the marker's normal and its line of sight [rad] (0 = seen face-on)."""
        z = self.pose[:3, 2]
        t = self.pose[:3, 3]
        return float(math.acos(min(1.0, abs(float(z @ t)) / float(np.linalg.norm(t)))))

    @property
    def bit_width(self):
        """Width of one bit across the marker's narrowest side in the image [px].

        The quad's area over its longest side is its smallest height; a tag of ``bits`` data
        bits a side spans ``bits + 2`` bits with its black border. Seen obliquely, a marker
        is a thin quad whose black border is a few pixels across although its sides are long:
        below :data:`MIN_BIT_WIDTH` its edges cannot be located apart from its data bits.
        """
        return quad_bit_width(self.corners, family_info(self.family).bits)

    def point_covariance(self, point):
        """Position of a point fixed to the marker, in the camera frame, with its covariance.

        Parameters
        ----------
        point : array_like, shape (3,)
            The point in the marker frame [m].

        Returns
        -------
        position : ndarray, shape (3,)
            The point in the camera frame [m].
        covariance : ndarray, shape (3, 3)
            Its covariance [m^2] (from :attr:`covariance`).
        """
        with needs_extra("vision"):
            import cv2

        p = np.asarray(point, dtype=float).reshape(3)
        rvec = cv2.Rodrigues(self.pose[:3, :3])[0].reshape(3)
        jac = np.zeros((3, 6))
        eps = 1e-6
        for k in range(3):
            dr = np.zeros(3)
            dr[k] = eps
            plus = cv2.Rodrigues(rvec + dr)[0] @ p
            minus = cv2.Rodrigues(rvec - dr)[0] @ p
            jac[:, k] = (plus - minus) / (2 * eps)
        jac[:, 3:] = np.eye(3)
        return self.pose[:3, :3] @ p + self.pose[:3, 3], jac @ self.covariance @ jac.T


def quad_bit_width(quad, bits):
    """Width of one bit across each side of a marker's quad [px], shape (4,) (or the smallest, a float).

    Parameters
    ----------
    quad : array_like, shape (4, 2)
        The marker's corners [px].
    bits : int
        Data bits a side (the black border adds one bit each way).

    Returns
    -------
    float
        The smallest width: the quad's area over its longest side, over ``bits + 2``.
    """
    return float(np.min(_side_bit_widths(np.asarray(quad, dtype=float), bits)))


def _side_bit_widths(quad, bits):
    ends = np.roll(quad, -1, axis=0)
    lengths = np.linalg.norm(ends - quad, axis=1)
    area = 0.5 * abs(float(np.sum(quad[:, 0] * ends[:, 1] - ends[:, 0] * quad[:, 1])))
    return area / np.maximum(lengths, 1e-12) / (bits + 2)


@functools.lru_cache(maxsize=None)
def _detector(family):
    with needs_extra("vision"):
        import cv2

    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE  # the edges are refined by _refine_edges
    params.adaptiveThreshWinSizeMin, params.adaptiveThreshWinSizeMax, params.adaptiveThreshWinSizeStep = 5, 25, 20
    return cv2.aruco.ArucoDetector(dictionary(family), params)


def _refine_edges(gray, quad, bits, camera):
    """Corners as intersections of the four edge lines, each fitted to sub-pixel edge points.

    Along each side of the black square, the grey level is sampled across the edge and the
    crossing of the mid level between the black border and the white quiet zone is the edge
    point (a symmetric blur does not move it, unlike a corner detector's saddle point on an
    L-shaped corner). The points are undistorted first, so the lines are straight.
    """
    with needs_extra("vision"):
        import cv2

    quad = np.asarray(quad, dtype=float)
    ends = np.roll(quad, -1, axis=0)
    # each profile reaches less than half a bit into the black border (beyond it lie the data bits), a bit
    # measured across its edge: the quad's height over that side, which is far less than the side when the
    # marker is seen obliquely (a thin quad)
    half = np.clip(_PROFILE_BIT_FRACTION * _side_bit_widths(quad, bits), _MIN_HALF_PROFILE, 4.0)
    steps = np.linspace(-1.0, 1.0, _PROFILE_SAMPLES)[None, :] * half[:, None]  # (4, s) [px]
    d = (ends - quad) / np.linalg.norm(ends - quad, axis=1, keepdims=True)
    n = np.column_stack([-d[:, 1], d[:, 0]])
    outward = np.sum(n * (quad - quad.mean(axis=0)), axis=1) < 0
    n[outward] *= -1  # from the black border to the white quiet zone
    base = quad[:, None, :] + _EDGE_FRACTIONS[None, :, None] * (ends - quad)[:, None, :]  # (4, m, 2)
    pts = base[:, :, None, :] + steps[:, None, :, None] * n[:, None, None, :]  # (4, m, s, 2)
    flat = pts.reshape(-1, _PROFILE_SAMPLES, 2).astype(np.float32)
    prof = cv2.remap(gray, flat[..., 0], flat[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    lo = prof[:, :4].mean(axis=1, keepdims=True)
    hi = prof[:, -4:].mean(axis=1, keepdims=True)
    mid = (lo + hi) / 2
    above = prof >= mid
    idx = np.argmax(above, axis=1)
    good = (hi[:, 0] - lo[:, 0] > 10) & (idx > 0)
    rows = np.arange(len(prof))
    i = np.maximum(idx, 1)
    p0, p1 = prof[rows, i - 1], prof[rows, i]
    frac = (mid[:, 0] - p0) / np.maximum(p1 - p0, 1e-6)
    side = rows // len(_EDGE_FRACTIONS)
    off = steps[side, i - 1] + frac * (steps[side, 1] - steps[side, 0])
    edge = base.reshape(-1, 2) + off[:, None] * np.repeat(n, len(_EDGE_FRACTIONS), axis=0)
    good = good.reshape(4, -1)
    if np.any(good.sum(axis=1) < 6):
        return quad
    xy = (edge if camera is None else camera.undistort_points(edge)).reshape(4, -1, 2)
    lines = np.empty((4, 3))
    for k in range(4):
        sel = xy[k][good[k]]
        mean = sel.mean(axis=0)
        c = np.cov(sel.T)
        # normal of the fitted line: the eigenvector of the smaller eigenvalue of the 2x2 scatter
        lam = 0.5 * (c[0, 0] + c[1, 1]) - np.sqrt(0.25 * (c[0, 0] - c[1, 1]) ** 2 + c[0, 1] ** 2)
        normal = np.array([c[0, 1], lam - c[0, 0]]) if abs(c[0, 1]) > 1e-300 else (
            np.array([1.0, 0.0]) if c[0, 0] < c[1, 1] else np.array([0.0, 1.0]))
        normal /= np.hypot(normal[0], normal[1])
        lines[k] = normal[0], normal[1], -(normal @ mean)
    a, b = np.roll(lines, 1, axis=0), lines
    corners = np.column_stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                               a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]])
    if np.any(np.abs(corners[:, 2]) < 1e-12):
        return quad
    corners = corners / corners[:, 2:]
    return corners[:, :2] if camera is None else camera.project(corners)


def detect_markers(image, family="tag36h11", camera=None):
    """Ids and sub-pixel corners of every marker of a family in an image (no pose).

    Parameters
    ----------
    image : ndarray, shape (h, w) or (h, w, 3)
        Grey or BGR image (uint8).
    family : str
        A key of :data:`labkit.vision.FAMILIES`.
    camera : Camera, optional
        The camera (its distortion straightens the edges before the corners are refined);
        default: no distortion.

    Returns
    -------
    ids : ndarray of int, shape (m,)
    corners : ndarray, shape (m, 4, 2)
        Corners [px], OpenCV's order.
    """
    with needs_extra("vision"):
        import cv2

    info = family_info(family)
    gray = _gray(image)
    if camera is not None and not isinstance(camera, Camera):
        raise OptionError(f"expected camera as a labkit.vision.Camera or None, got {camera!r}")
    detector = _detector(info.name)
    corners, ids = None, None
    if max(gray.shape) >= _DOWNSCALE_ABOVE:
        # find the quads at half resolution (4x fewer pixels to threshold), refine them at full resolution
        small = cv2.resize(gray, (gray.shape[1] // 2, gray.shape[0] // 2), interpolation=cv2.INTER_AREA)
        corners, ids, _ = detector.detectMarkers(small)
        if ids is not None and len(ids):
            corners = [c * 2.0 + 0.5 for c in corners]
    if ids is None or not len(ids):
        corners, ids, _ = detector.detectMarkers(gray)
    if ids is None or not len(ids):
        return np.zeros(0, dtype=int), np.zeros((0, 4, 2))
    grayf = gray.astype(np.float32)
    refined = []
    for c in corners:
        quad = c.reshape(4, 2)
        for _ in range(2):  # the second pass starts from straight edges, a fraction of a pixel off
            quad = _refine_edges(grayf, quad, info.bits, camera)
        refined.append(quad)
    return ids.reshape(-1).astype(int), np.array(refined, dtype=float)


def _pose_from_corners(corners, camera, size, corner_sigma):
    with needs_extra("vision"):
        import cv2

    obj = marker_corners(size)
    n, rvecs, tvecs, errors = cv2.solvePnPGeneric(obj, corners.reshape(4, 1, 2), camera.matrix, camera.distortion,
                                                  flags=cv2.SOLVEPNP_IPPE_SQUARE)
    errors = np.asarray(errors, dtype=float).reshape(-1) if errors is not None else np.full(n, np.nan)
    order = np.argsort(errors)
    best = int(order[0])
    rvec, tvec = rvecs[best].reshape(3), tvecs[best].reshape(3)
    err = float(errors[best])
    alt = float(errors[int(order[1])]) if n > 1 else math.inf
    uv, jac = cv2.projectPoints(obj.reshape(4, 1, 3), rvec, tvec, camera.matrix, camera.distortion)
    J = jac[:, :6]
    sigma = max(corner_sigma, err)
    # a corner is the crossing of two edge lines, each off by sigma across itself: its covariance is
    # sigma^2 (N^T N)^-1, N the two edges' unit normals (the identity at a right angle), so the sharp
    # corners of a marker seen obliquely (a thin quad) are uncertain along their bisector
    edges = np.roll(corners, -1, axis=0) - corners  # edge k runs from corner k to corner k + 1
    normals = np.column_stack([-edges[:, 1], edges[:, 0]]) / np.maximum(np.linalg.norm(edges, axis=1), 1e-12)[:, None]
    pair = np.stack([np.roll(normals, 1, axis=0), normals], axis=1)  # (4, 2, 2): the edges meeting at each corner
    information = np.zeros((8, 8))
    for k in range(4):
        information[2 * k:2 * k + 2, 2 * k:2 * k + 2] = pair[k].T @ pair[k]
    try:
        cov = sigma ** 2 * np.linalg.inv(J.T @ information @ J)
    except np.linalg.LinAlgError:
        cov = np.full((6, 6), np.inf)
    R = cv2.Rodrigues(rvec)[0]
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = R, tvec
    return pose, cov, err, alt, sigma


def marker_poses(image, camera, size, family="tag36h11", *, ids=None, corner_sigma=DEFAULT_CORNER_SIGMA,
                 ambiguity_ratio=AMBIGUITY_RATIO, on_ambiguous="raise"):
    """Detect the markers of a family in an image and solve their poses.

    Parameters
    ----------
    image : ndarray, shape (h, w) or (h, w, 3)
        Grey or BGR image (uint8), taken with ``camera``.
    camera : Camera
        Intrinsics and distortion of the camera that took the image.
    size : float or mapping
        Side of the black square [m]; a mapping ``{id: size}`` for markers of several sizes.
    family : str
        Marker family (default ``"tag36h11"``; see :data:`labkit.vision.FAMILIES`).
    ids : int or sequence of int, optional
        Only these ids; a marker of another id is ignored.
    corner_sigma : float
        A-priori standard deviation of a corner [px]; the pose covariance uses
        ``max(corner_sigma, RMS reprojection error)``.
    ambiguity_ratio : float
        The pose is ambiguous when the other IPPE solution's error is below
        ``ambiguity_ratio * max(error, corner_sigma)``.
    on_ambiguous : {"raise", "keep"}
        Raise :class:`AmbiguousPoseError`, or keep the detection (``ambiguous=True``).

    Returns
    -------
    list of MarkerDetection
        Sorted by id.

    Raises
    ------
    MarkerNotFoundError
        No marker of the family in the image.
    WrongMarkerError
        Markers found, but none with the ids asked for (the message lists what was seen).
    AmbiguousPoseError
        A marker's pose is ambiguous and ``on_ambiguous="raise"``.

    Examples
    --------
    >>> import numpy as np
    >>> from labkit.vision import Camera, VirtualCamera
    >>> cam = Camera.pinhole(1000.0, (640, 480))
    >>> pose = np.eye(4); pose[:3, 3] = [0.01, 0.0, 0.4]
    >>> pose[:3, :3] = [[1, 0, 0], [0, -0.866, -0.5], [0, 0.5, -0.866]]  # tilted 30 deg
    >>> image = VirtualCamera(cam, noise=0.0).render_markers({7: pose}, size=0.04)
    >>> [d] = marker_poses(image, cam, 0.04)
    >>> d.id, bool(np.linalg.norm(d.position - pose[:3, 3]) < 1e-3)
    (7, True)
    """
    on_ambiguous = as_option(on_ambiguous, _ON_AMBIGUOUS, "on_ambiguous")
    corner_sigma = as_number(corner_sigma, "corner_sigma", unit="px", positive=True, error=OptionError)
    ambiguity_ratio = as_number(ambiguity_ratio, "ambiguity_ratio", positive=True, error=OptionError)
    count = family_info(family).count
    if ids is not None:
        try:
            listed = [ids] if np.ndim(ids) == 0 else list(ids)
        except (TypeError, ValueError):  # ragged, or nothing numpy can size
            listed = [ids]
        ids = [as_count(i, f"ids as {family} ids", maximum=count - 1) for i in listed]
    if not isinstance(size, dict):
        marker_size(size, None)
    found_ids, corners = detect_markers(image, family, camera)
    if not len(found_ids):
        raise MarkerNotFoundError(f"expected at least one {family} marker in the image, found none "
                                  "(check focus, light, the family and that the whole marker with its white "
                                  "border is in view)")
    wanted = None if ids is None else set(ids)
    keep = [k for k, i in enumerate(found_ids) if wanted is None or i in wanted]
    if not keep:
        raise WrongMarkerError(f"expected {family} marker id(s) {sorted(wanted)}, found id(s) "
                               f"{sorted(set(found_ids.tolist()))}")
    out = []
    for k in keep:
        mid = int(found_ids[k])
        s = marker_size(size, mid)
        pose, cov, err, alt, sigma = _pose_from_corners(corners[k], camera, s, corner_sigma)
        ambiguous = bool(alt < ambiguity_ratio * max(err, corner_sigma))
        if ambiguous and on_ambiguous == "raise":
            raise AmbiguousPoseError(
                f"marker {mid}: expected one clear pose, got two that fit the corners about equally "
                f"({err:.3f} px vs {alt:.3f} px RMS); the marker is seen too face-on or too small: "
                "tilt it (or the camera) by 20 deg or more, or move closer")
        out.append(MarkerDetection(mid, pose, corners[k].copy(), cov, err, alt, ambiguous, s, family))
    return sorted(out, key=lambda d: d.id)
