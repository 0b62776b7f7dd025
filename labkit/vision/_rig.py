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

from labkit.robot import Robot
from labkit.kinematics import fk_position
from labkit.vision._camera import Camera
from labkit.vision._families import texture_extent

__all__ = ["CameraRig", "look_at", "face_marker"]


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
    """
    eye, target, up = (np.asarray(v, dtype=float) for v in (eye, target, up))
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
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
    """
    z = np.asarray(normal, dtype=float)
    z = z / np.linalg.norm(z)
    x = np.asarray(along, dtype=float)
    x = x - (x @ z) * z
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    T[:3, 3] = centre
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
    def around(cls, robot, *, camera=None, marker_size=None, reference_size=None, standoff=None,
               distance_factor=1.25, seed=0):
        """A default rig for an arm: the camera above and to the side of the workspace.

        Five markers on the gripper sit on the faces of a cube around the tool point
        (ids 1-5 facing the tool's -z, -y, +z, +y and +x axes; ``standoff`` from the tool
        point), so one faces the camera in most orientations; four reference markers
        (ids 10-13) lie on a sheet below the workspace, facing up. The camera is placed along the base's +y and up, far enough
        for the sampled workspace to fit its vertical field of view.

        Parameters
        ----------
        robot : Robot or str
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
            Margin on the camera distance (1 = the workspace just fits).
        seed : int
            Seed of the joint samples that estimate the workspace.

        Returns
        -------
        CameraRig
        """
        robot = Robot.load(robot)
        if camera is None:
            camera = Camera.pinhole(1000.0, (1280, 960), distortion=[-0.08, 0.05, 0.0, 0.0, 0.0], name="virtual webcam")
        lim = robot.joint_limits
        q = np.random.default_rng(seed).uniform(lim[:, 0], lim[:, 1], (400, robot.n))
        pts = fk_position(robot, q)
        up = np.asarray(robot.up, dtype=float)
        centre = pts.mean(axis=0)
        radius = float(np.percentile(np.linalg.norm(pts - centre, axis=1), 90))
        side = np.array([0.1, 0.75, 0.0])
        side = side - (side @ up) * up
        direction = side / np.linalg.norm(side) * 0.75 + up * 0.65
        direction /= np.linalg.norm(direction)
        fov_v = camera.field_of_view()[1]
        dist = distance_factor * radius / np.tan(fov_v / 2)
        eye = centre + dist * direction
        if marker_size is None:
            marker_size = max(0.04, math.ceil(80.0 * dist / camera.focal[0] / 0.005) * 0.005)
        if reference_size is None:
            reference_size = 1.5 * marker_size
        if standoff is None:
            standoff = texture_extent("tag36h11", marker_size) / 2
        base_from_camera = look_at(eye, centre, up)
        low = float(np.min(pts @ up)) - 0.02
        sheet = centre - (centre @ up) * up + low * up
        x_axis = np.array([1.0, 0.0, 0.0]) - up * up[0]
        y_axis = np.cross(up, x_axis / np.linalg.norm(x_axis))
        base_markers = {}
        for k, (sx, sy) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)]):
            c = sheet + max(0.1, 1.2 * texture_extent("tag36h11", reference_size)) * (sx * x_axis / np.linalg.norm(x_axis) + sy * y_axis)
            base_markers[10 + k] = face_marker(up, x_axis, c)
        # a cube around the tool point, a tag on each face but the one towards the arm (-x)
        faces = {1: ([0, 0, -1], [1, 0, 0]), 2: ([0, -1, 0], [1, 0, 0]), 3: ([0, 0, 1], [1, 0, 0]),
                 4: ([0, 1, 0], [1, 0, 0]), 5: ([1, 0, 0], [0, 1, 0])}
        tool_markers = {k: face_marker(n, a, standoff * np.asarray(n, float)) for k, (n, a) in faces.items()}
        size = {**{k: float(marker_size) for k in tool_markers}, **{k: float(reference_size) for k in base_markers}}
        return cls(camera, base_from_camera, tool_markers, base_markers, size)

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
