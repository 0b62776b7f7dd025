"""A camera set-up around an arm (:class:`CameraRig`): where the camera, the gripper's markers
and the reference markers are, and a default placement that sees an arm's workspace.

Examples
--------
>>> rig = CameraRig.around("arduino_arm_3dof")
>>> sorted(rig.tool_markers), sorted(rig.base_markers)
([1, 2, 3, 4, 5], [10, 11, 12, 13])
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from labkit.exceptions import ShapeError
from labkit.validation import as_batch, as_number, as_seed
from labkit.robot import Robot
from labkit.kinematics import fk, fk_position
from labkit.vision._camera import Camera
from labkit.vision._families import texture_extent

__all__ = ["CameraRig", "look_at", "face_marker"]


def _marker_sizes(camera, dist, marker_size, reference_size, standoff):
    """The gripper's and the reference tags' sides and the tags' standoff [m] for a camera ``dist`` away [m]:
    those given, else a gripper tag of at least 80 px (40 mm or more, in 5 mm steps; 40 mm when ``dist`` is None),
    reference tags 1.5 times larger, the standoff half the gripper tag's printed side (a cube)."""
    size = 0.04 if dist is None else max(0.04, math.ceil(80.0 * dist / camera.focal[0] / 0.005) * 0.005)
    size = size if marker_size is None else marker_size
    reference = 1.5 * size if reference_size is None else reference_size
    return size, reference, texture_extent("tag36h11", size) / 2 if standoff is None else standoff


#: the normals of the gripper cube's tags in the tool frame (ids 1-5: -z, -y, +z, +y, +x; none towards the arm)
_FACES = np.array([[0, 0, -1], [0, -1, 0], [0, 0, 1], [0, 1, 0], [1, 0, 0]], dtype=float)


def _place(camera, pts, up, x_axis, y_axis, direction, given, margin):
    """Where a camera looking back along ``direction`` sees the tool points ``pts`` (shape (k, 3) [m]) with their tag
    cubes and the reference sheet below them: ``(centre, distance, sizes, spots)``.

    The gripper tags follow the distance (80 px, :func:`_marker_sizes` with the ``given`` sizes and standoff), the
    distance their cubes; the reference tags are sized for the poses alone, then their sheet joins what the camera
    must see (:func:`_fit_distance` with ``margin``)."""
    marker_size, reference, standoff = given
    middle = (pts.min(axis=0) + pts.max(axis=0)) / 2
    dist, with_sheet = None, False
    for _ in range(50):
        sizes = _marker_sizes(camera, dist, marker_size, reference, standoff)
        cube = math.hypot(sizes[2], texture_extent("tag36h11", sizes[0]) / math.sqrt(2))  # to a tag corner
        spots, corners = _sheet(middle, float(np.min(pts @ up)) - cube - 0.02, up, x_axis, y_axis, sizes[1])
        seen = np.vstack([pts, corners]) if with_sheet else pts
        radii = np.r_[np.full(len(pts), cube), np.zeros(len(seen) - len(pts))]
        centre = (np.min(seen - radii[:, None], axis=0) + np.max(seen + radii[:, None], axis=0)) / 2
        needed = _fit_distance(camera, centre, direction, up, seen, radii, margin)
        settled, dist = dist is not None and abs(needed - dist) <= 1e-3 * dist, needed
        if settled and with_sheet:
            break
        with_sheet, reference = (True, sizes[1]) if settled else (with_sheet, reference)
    return centre, dist, sizes, spots


def _sheet(middle, low, up, x_axis, y_axis, reference):
    """Centres (list of 4 of shape (3,)) and corners (shape (16, 3)) of the reference tags [m]: a sheet at height
    ``low`` [m] along ``up``, under ``middle``, with tags of side ``reference`` [m] facing up."""
    sheet = middle - (middle @ up) * up + low * up
    ext = texture_extent("tag36h11", reference)
    spots = [sheet + max(0.1, 1.2 * ext) * (sx * x_axis + sy * y_axis) for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    corners = np.array([c + ext / 2 * (ex * x_axis + ey * y_axis) for c in spots for ex in (-1, 1) for ey in (-1, 1)])
    return spots, corners


def _fit_distance(camera, centre, direction, up, points, radii, margin):
    """How far from ``centre`` along ``direction`` a camera looking at it must stand for every point (a ball of
    its radius) to lie inside its image, whose half-widths are divided by ``margin`` [m].

    Parameters
    ----------
    camera : Camera
    centre, direction, up : ndarray, shape (3,)
        The point looked at [m], the unit direction from it to the camera, the world's up.
    points : ndarray, shape (k, 3)
        Points in the base frame [m].
    radii : ndarray, shape (k,)
        Radius of the ball around each point that must fit too [m].
    margin : float

    Returns
    -------
    float
        The distance [m]: for a point at lateral offset ``x`` and height ``y`` in the image's axes and ``s`` towards
        the camera, ``|x| + r <= t (D - s - r)`` with ``t`` the tangent of the half field of view.
    """
    R = look_at(centre + direction, centre, up)[:3, :3]  # the camera's axes, as it will be placed
    rel = (points - centre) @ R  # x right, y down, z forward (away from the camera)
    fov = camera.field_of_view()
    t = np.tan(np.asarray(fov) / 2) / margin
    lateral = np.maximum((np.abs(rel[:, 0]) + radii) / t[0], (np.abs(rel[:, 1]) + radii) / t[1])
    return float(np.max(lateral - rel[:, 2] + radii))


#: the largest margin on the camera distance of :meth:`CameraRig.around` (more leaves the arm a few pixels)
MAX_DISTANCE_FACTOR = 100.0
#: the farthest coordinate a rig's points take [m] (a lab is metres across; beyond it a difference may overflow)
FARTHEST = 1e9


def _point(value, name):
    """``value`` as a finite point of shape (3,) within :data:`FARTHEST` [m], or a ShapeError."""
    p = as_batch(value, (3,), name, batch=False)
    if np.abs(p).max() > FARTHEST:
        raise ShapeError(f"expected {name} within +-{FARTHEST:g} m, got {p.tolist()}")
    return p


def _direction(value, name):
    """``value`` as a unit vector of shape (3,), or a ShapeError (a zero or non-finite vector has no direction)."""
    v = as_batch(value, (3,), name, batch=False)
    scale = np.abs(v).max()
    if not scale > 0:
        raise ShapeError(f"expected {name} as a non-zero direction, got {v.tolist()}")
    v = v / scale  # no overflow in the norm of a huge vector
    return v / np.linalg.norm(v)


def _across(a, b, name):
    """The unit vector ``a x b`` (a and b unit vectors), or a ShapeError when they are parallel."""
    c = np.cross(a, b)
    norm = np.linalg.norm(c)
    if not norm > 1e-9:
        raise ShapeError(f"expected {name}, got parallel directions {a.tolist()} and {b.tolist()}")
    return c / norm


def look_at(eye, target, up):
    """Pose of a camera at ``eye`` looking at ``target`` (OpenCV camera axes: z forward, y down).

    Parameters
    ----------
    eye, target : array_like, shape (3,)
        Camera centre and the point it looks at [m].
    up : array_like, shape (3,)
        The world's up direction (the image's top points towards it).

    Returns
    -------
    ndarray, shape (4, 4)
        ``world_from_camera``.

    Raises
    ------
    ShapeError
        Not three finite numbers each, a target at the eye, or ``up`` along the line of sight.
    """
    eye, target = _point(eye, "eye"), _point(target, "target")
    z = _direction(target - eye, "target - eye (a target away from the eye)")
    x = _across(z, _direction(up, "up"), "an up direction not along the line of sight")
    y = np.cross(z, x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, y, z])
    T[:3, 3] = eye
    return T


def face_marker(normal, along, centre):
    """Pose of a marker whose printed face points along ``normal`` (its x axis along ``along``).

    Parameters
    ----------
    normal, along : array_like, shape (3,)
        Directions in the parent frame (``along`` is made orthogonal to ``normal``).
    centre : array_like, shape (3,)
        Centre of the marker in the parent frame [m].

    Returns
    -------
    ndarray, shape (4, 4)
        ``parent_from_marker``.

    Raises
    ------
    ShapeError
        Not three finite numbers each, a zero direction, or ``along`` parallel to ``normal``.
    """
    z = _direction(normal, "normal")
    y = _across(z, _direction(along, "along"), "along not parallel to normal")
    x = np.cross(y, z)  # along made orthogonal to normal
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, y, z])
    T[:3, 3] = _point(centre, "centre")
    return T


@dataclasses.dataclass(frozen=True, eq=False)
class CameraRig:
    """A fixed camera watching an arm (eye-to-hand), markers on the gripper, reference markers on the base.

    Attributes
    ----------
    camera : Camera
        The camera's intrinsics (for a virtual rig: the truth).
    base_from_camera : ndarray, shape (4, 4)
        Where the camera is in the base frame [m] (for a virtual rig: the truth; a
        session measures it from the reference markers).
    tool_markers : dict
        ``{id: tool_from_marker}``: markers on the gripper [m].
    base_markers : dict
        ``{id: base_from_marker}``: reference markers fixed to the base [m].
    size : dict
        ``{id: side of the black square [m]}``.
    family : str
    """

    camera: Camera
    base_from_camera: np.ndarray
    tool_markers: dict
    base_markers: dict
    size: dict
    family: str = "tag36h11"

    @classmethod
    def around(cls, robot, poses=None, *, camera=None, marker_size=None, reference_size=None, standoff=None,
               distance_factor=1.25, seed=0):
        """A default rig for an arm: the camera above and to the side of the poses it measures.

        Five markers on the gripper sit on the faces of a cube around the tool point
        (ids 1-5 facing the tool's -z, -y, +z, +y and +x axes; ``standoff`` from the tool
        point), so one faces the camera in most orientations; four reference markers
        (ids 10-13) lie on a sheet below the tool, facing up. The camera stands on the base's +y
        side, above, looking down at the poses. Given ``poses``, it stands back just far enough for every pose's marker cube
        and the reference sheet to lie inside its image, ``distance_factor`` inside the edges
        (:meth:`in_view` checks a point), on the side (the default one, or turned about up in 45-degree
        steps) from which the most poses show a gripper tag 20 to 70 degrees off its face (a tag seen
        head-on has an ambiguous pose, one seen edge-on too few pixels per bit); without ``poses``, far
        enough for the sphere holding 90 % of a sample of the workspace (an outstretched pose of a
        long arm may leave the view).

        Parameters
        ----------
        robot : Robot or str
        poses : array_like, shape (k, n), optional
            Joint values [rad | m] of the poses the camera must see (a lab's measurement plan).
        camera : Camera, optional
            Default: a 1280x960 camera with f = 1000 px and a little barrel distortion.
        marker_size, reference_size : float, optional
            Sides of the gripper's and the reference markers' black squares [m]; default:
            a gripper tag that spans at least 80 px at the camera's distance (40 mm or more,
            in steps of 5 mm), reference tags 1.5 times larger.
        standoff : float, optional
            Distance of the gripper markers from the tool point [m] (default: half the
            printed side, so the markers are the faces of one cube around the tool point).
        distance_factor : float
            Margin on the camera distance (1 = the workspace just fits); with ``poses``, the
            image's half-widths are divided by it.
        seed : int
            Seed of the joint samples that estimate the workspace (without ``poses``).

        Returns
        -------
        CameraRig

        Raises
        ------
        ShapeError
            ``poses`` is not a non-empty (k, n) array of finite joint values; a size, standoff or
            ``distance_factor`` (at most :data:`MAX_DISTANCE_FACTOR`) that is not a positive finite number, a
            camera that is not a :class:`Camera`.
        OptionError
            A seed that is not an integer >= 0, a Generator or None.
        """
        robot = Robot.load(robot)
        distance_factor = as_number(distance_factor, "distance_factor", positive=True)
        if distance_factor > MAX_DISTANCE_FACTOR:
            raise ShapeError(f"expected distance_factor at most {MAX_DISTANCE_FACTOR:g}, got {distance_factor:g}")
        seed = as_seed(seed)
        for name, value in (("marker_size", marker_size), ("reference_size", reference_size), ("standoff", standoff)):
            if value is not None:
                as_number(value, name, unit="m", positive=True)
        if camera is not None and not isinstance(camera, Camera):
            raise ShapeError(f"expected camera as a labkit.vision.Camera or None, got {camera!r}")
        if camera is None:
            camera = Camera.pinhole(1000.0, (1280, 960), distortion=[-0.08, 0.05, 0.0, 0.0, 0.0], name="virtual webcam")
        up = np.asarray(robot.up, dtype=float)
        x_axis = np.array([1.0, 0.0, 0.0]) - up * up[0]
        x_axis /= np.linalg.norm(x_axis)
        y_axis = np.cross(up, x_axis)
        side = np.array([0.1, 0.75, 0.0])
        side = side - (side @ up) * up
        direction = side / np.linalg.norm(side) * 0.75 + up * 0.65
        direction /= np.linalg.norm(direction)
        if poses is None:
            lim = robot.joint_limits
            pts = fk_position(robot, np.random.default_rng(seed).uniform(lim[:, 0], lim[:, 1], (400, robot.n)))
            centre = pts.mean(axis=0)
            radius = float(np.percentile(np.linalg.norm(pts - centre, axis=1), 90))
            dist = distance_factor * radius / np.tan(camera.field_of_view()[1] / 2)
            sizes = _marker_sizes(camera, dist, marker_size, reference_size, standoff)
            spots, _ = _sheet(centre, float(np.min(pts @ up)) - 0.02, up, x_axis, y_axis, sizes[1])
        else:
            q = as_batch(poses, (robot.n,), "poses")
            if q.ndim != 2 or len(q) == 0:
                raise ShapeError(f"expected poses of shape (k, {robot.n}) with k >= 1 finite joint values, "
                                 f"got shape {q.shape}")
            T = fk(robot, q)
            pts = T[:, :3, 3]
            # the default side first; another where it sees more poses with a gripper tag at a readable angle
            best = None
            for turn in np.radians([0, 45, -45, 90, -90, 135, -135, 180]):
                c, s_ = math.cos(turn), math.sin(turn)
                d = direction * c + np.cross(up, direction) * s_ + up * (up @ direction) * (1 - c)  # Rodrigues about up
                centre_, dist_, sizes_, spots_ = _place(camera, pts, up, x_axis, y_axis, d,
                                                        (marker_size, reference_size, standoff), distance_factor)
                eye = centre_ + dist_ * d
                normals = np.einsum("kij,mj->kmi", T[:, :3, :3], _FACES)  # (k, 5, 3): the tags' normals in the base
                rays = eye - pts
                cosine = np.einsum("kmi,ki->km", normals, rays / np.linalg.norm(rays, axis=1, keepdims=True))
                score = int(np.sum(np.any((cosine > math.cos(math.radians(70))) & (cosine < math.cos(math.radians(20))),
                                          axis=1)))
                if best is None or score > best[0]:
                    best = (score, centre_, dist_, sizes_, spots_, d)
            _, centre, dist, sizes, spots, direction = best
        marker_size, reference_size, standoff = sizes
        eye = centre + dist * direction
        base_from_camera = look_at(eye, centre, up)
        base_markers = {10 + k: face_marker(up, x_axis, c) for k, c in enumerate(spots)}
        # a cube around the tool point, a tag on each face but the one towards the arm (-x)
        along = {1: [1, 0, 0], 2: [1, 0, 0], 3: [1, 0, 0], 4: [1, 0, 0], 5: [0, 1, 0]}
        tool_markers = {k: face_marker(n, along[k], standoff * n) for k, n in zip(along, _FACES)}
        size = {**{k: float(marker_size) for k in tool_markers}, **{k: float(reference_size) for k in base_markers}}
        return cls(camera, base_from_camera, tool_markers, base_markers, size)

    def in_view(self, points, margin=0.0):
        """Whether points lie in front of the camera and inside its image.

        Parameters
        ----------
        points : array_like, shape (..., 3)
            Points in the base frame [m] (e.g. the tool points of a plan, ``fk_position(robot, q)``).
        margin : float
            Distance the points must keep from the image's edges [px].

        Returns
        -------
        ndarray of bool, shape (...)
        """
        p = np.asarray(points, dtype=float)
        if p.shape[-1:] != (3,):
            raise ShapeError(f"expected points with shape (..., 3), got {p.shape}")
        camera_from_base = np.linalg.inv(self.base_from_camera)
        local = p @ camera_from_base[:3, :3].T + camera_from_base[:3, 3]
        uv = self.camera.project(local)
        w, h = self.camera.image_size
        inside = (uv[..., 0] >= margin - 0.5) & (uv[..., 0] <= w - 0.5 - margin)
        inside &= (uv[..., 1] >= margin - 0.5) & (uv[..., 1] <= h - 0.5 - margin)
        # a ray wider than the image's corners can fold back into the image through the distortion polynomial
        corners = self.camera.undistort_points(np.array([[-0.5, -0.5], [w - 0.5, -0.5], [-0.5, h - 0.5], [w - 0.5, h - 0.5]]))
        with np.errstate(divide="ignore", invalid="ignore"):
            ray = np.linalg.norm(local[..., :2] / local[..., 2:], axis=-1)
        return inside & (local[..., 2] > 0) & (ray <= np.linalg.norm(corners, axis=-1).max())

    def virtual_camera(self, arm, **options):
        """A :class:`VirtualCamera` of this rig on a virtual arm.

        Parameters
        ----------
        arm : labkit.arm.Arm or labkit.arm.ArmModel
            A virtual arm (``sim://``).
        **options
            Passed to :class:`VirtualCamera` (``noise``, ``blur``, ``gain``, ``seed`` ...).

        Returns
        -------
        VirtualCamera
        """
        from labkit.vision._virtual import VirtualCamera

        return VirtualCamera(self.camera, arm=arm, base_from_camera=self.base_from_camera,
                             tool_markers=self.tool_markers, base_markers=self.base_markers, size=self.size,
                             family=self.family, **options)
