"""The virtual camera (:class:`VirtualCamera`): images of markers and boards with known truth.

A :class:`VirtualCamera` renders printed sheets (markers, calibration boards)
at given poses through a pinhole-plus-distortion :class:`Camera`, with
lighting (level, gradient), lens blur and sensor noise. Attached to a virtual
arm (``sim://``; :attr:`labkit.arm.Arm.virtual_model`), it renders the markers
mounted on the gripper at the pose the arm **really** reached (its true joint
values, with zero offsets and gravity sag, :attr:`labkit.arm.ArmModel.true_q`)
and the reference markers fixed to the base, so a camera measurement can be
checked against the truth.
"""

from __future__ import annotations

import numpy as np

from labkit.exceptions import OptionError, ShapeError
from labkit.kinematics import fk
from labkit.validation import as_batch, as_count, as_number, as_seed
from labkit.vision._boards import CharucoBoard, Checkerboard
from labkit.vision._camera import Camera
from labkit.vision._families import family_info, marker_texture, texture_extent
from labkit.vision._markers import marker_size
from labkit.vision._render import Plane, RayMap, draw_planes, expose

__all__ = ["VirtualCamera"]


#: pixel rays of the last few camera models (keyed by their numbers): one per model, not per VirtualCamera
_RAY_MAPS = {}


def _pose(T, name):
    return as_batch(T, (4, 4), f"{name} as a finite 4x4 transform", batch=False)


def _markers(markers, name):
    """``{id: pose}`` checked: a mapping of marker ids (integers >= 0) to finite 4x4 transforms."""
    if not isinstance(markers, dict):
        raise OptionError(f"expected {name} as a mapping {{id: 4x4 pose}}, got {markers!r}")
    return {as_count(k, f"{name} ids"): _pose(v, f"{name}[{k!r}]") for k, v in markers.items()}


def _fraction(value, name):
    """``value`` as a finite number in 0..1, or a ShapeError."""
    out = as_number(value, f"{name} in 0..1", minimum=0.0)
    if out > 1.0:
        raise ShapeError(f"expected {name} in 0..1, got {value!r}")
    return out


class VirtualCamera:
    """A simulated camera that renders markers and boards with known truth.

    Parameters
    ----------
    camera : Camera
        The true intrinsics and distortion (needs ``image_size``).
    arm : labkit.arm.Arm or labkit.arm.ArmModel, optional
        A virtual arm; its true reached pose places ``tool_markers``.
    base_from_camera : array_like, shape (4, 4), optional
        Pose of the camera in the robot's base frame [m] (needed with ``arm`` or ``base_markers``).
    tool_markers : mapping, optional
        ``{id: tool_from_marker}``: markers mounted on the gripper, their poses in the tool frame [m].
    base_markers : mapping, optional
        ``{id: base_from_marker}``: reference markers fixed in the base frame [m].
    size : float or mapping
        Side of a marker's black square [m] (or ``{id: size}``).
    family : str
        Marker family of the scene.
    noise : float
        Sensor noise [grey levels, standard deviation].
    blur : float
        Lens blur [px, standard deviation of a Gaussian].
    gain, offset : float
        Grey level of white paper and of black, as fractions of full scale.
    gradient : tuple of float
        Relative change of the light across the image (x, y) [1].
    background : float
        Reflectance of the background (0 black .. 1 white).
    seed : int
        Seed of the noise.

    Examples
    --------
    >>> from labkit.vision import Camera
    >>> cam = VirtualCamera(Camera.pinhole(800.0, (320, 240)), noise=0.0)
    >>> pose = np.eye(4); pose[:3, :3] = np.diag([1.0, -1.0, -1.0]); pose[2, 3] = 0.5
    >>> image = cam.render_markers({0: pose}, size=0.05)
    >>> image.shape, image.dtype
    ((240, 320), dtype('uint8'))
    """

    def __init__(self, camera, *, arm=None, base_from_camera=None, tool_markers=None, base_markers=None,
                 size=0.04, family="tag36h11", noise=1.5, blur=0.6, gain=0.8, offset=0.05,
                 gradient=(0.25, 0.1), background=0.45, seed=0):
        if not isinstance(camera, Camera):
            raise OptionError(f"expected camera as a labkit.vision.Camera, got {camera!r}")
        if camera.image_size is None:
            raise ShapeError("expected a camera with image_size (width, height), got None")
        family_info(family)
        self.camera = camera
        self.model = None if arm is None else getattr(arm, "virtual_model", arm)
        if arm is not None and (self.model is None or not hasattr(self.model, "true_q")):
            raise OptionError("expected a virtual arm (sim://, or an ArmModel), got an arm without a virtual model")
        self.base_from_camera = None if base_from_camera is None else _pose(base_from_camera, "base_from_camera")
        if (arm is not None or base_markers) and self.base_from_camera is None:
            raise OptionError("expected base_from_camera with an arm or base markers, got None")
        self.tool_markers = _markers(tool_markers or {}, "tool_markers")
        self.base_markers = _markers(base_markers or {}, "base_markers")
        self.size = size
        self.family = family
        for marker_id in {*self.tool_markers, *self.base_markers} if isinstance(size, dict) else (None,):
            self._marker_size(marker_id)
        self.noise = as_number(noise, "noise", unit="grey levels", minimum=0.0)
        self.blur = as_number(blur, "blur", unit="px", minimum=0.0)
        self.gain, self.offset = _fraction(gain, "gain"), _fraction(offset, "offset")
        self.gradient = tuple(as_batch(gradient, (2,), "gradient (x, y)", batch=False).tolist())
        self.background = _fraction(background, "background")
        self.rng = np.random.default_rng(as_seed(seed))
        self._rays = None
        self._textures = {}

    # -- low level -----------------------------------------------------------------
    @property
    def rays(self):
        """The camera's pixel rays (:class:`RayMap`, computed on first use)."""
        if self._rays is None:
            c = self.camera
            key = (c.matrix.tobytes(), c.distortion.tobytes(), c.image_size)
            if key not in _RAY_MAPS:
                while len(_RAY_MAPS) >= 4:
                    _RAY_MAPS.pop(next(iter(_RAY_MAPS)))
                _RAY_MAPS[key] = RayMap(c)
            self._rays = _RAY_MAPS[key]
        return self._rays

    def render(self, planes):
        """Render printed sheets into one exposed image.

        Parameters
        ----------
        planes : sequence of Plane
            Sheets with their poses in the camera frame.

        Returns
        -------
        ndarray, shape (height, width), uint8
        """
        w, h = self.camera.image_size
        canvas = np.full((h, w), self.background, dtype=np.float32)
        draw_planes(canvas, self.rays, planes)
        return expose(canvas, gain=self.gain, offset=self.offset, gradient=self.gradient, blur=self.blur,
                      noise=self.noise, rng=self.rng)

    def _marker_size(self, marker_id, size=None):
        return marker_size(self.size if size is None else size, marker_id)

    def marker_plane(self, marker_id, camera_from_marker, size=None, family=None):
        """The printed sheet of one marker (with its white quiet zone) at a pose.

        Parameters
        ----------
        marker_id : int
        camera_from_marker : array_like, shape (4, 4)
            Pose of the marker in the camera frame [m].
        size : float, optional
            Side of the black square [m] (default the camera's ``size``).
        family : str, optional
            Default the camera's ``family``.

        Returns
        -------
        Plane
        """
        family = self.family if family is None else family
        key = (family, as_count(marker_id, f"a {family} id", maximum=family_info(family).count - 1))
        if key not in self._textures:
            self._textures[key] = marker_texture(family, marker_id)
        s = texture_extent(family, self._marker_size(marker_id, size))
        return Plane(_pose(camera_from_marker, "camera_from_marker"), self._textures[key], (s, s))

    def render_markers(self, poses, size=None, family=None):
        """Render markers at poses in the camera frame.

        Parameters
        ----------
        poses : mapping
            ``{id: camera_from_marker}`` [m].
        size : float or mapping, optional
            Side of the black squares [m] (default the camera's ``size``).
        family : str, optional

        Returns
        -------
        ndarray, shape (height, width), uint8
        """
        poses = _markers(poses, "poses")
        return self.render([self.marker_plane(k, T, size, family) for k, T in poses.items()])

    def render_board(self, board, camera_from_board, pixels_per_square=None):
        """Render a calibration board at a pose in the camera frame.

        Parameters
        ----------
        board : Checkerboard or CharucoBoard
        camera_from_board : array_like, shape (4, 4)
            Pose of the board in the camera frame [m].
        pixels_per_square : int, optional
            Texture resolution (default the board's).

        Returns
        -------
        ndarray, shape (height, width), uint8
        """
        if not isinstance(board, (Checkerboard, CharucoBoard)):
            raise OptionError(f"expected board as a Checkerboard or a CharucoBoard, got {board!r}")
        key = ("board", board, pixels_per_square)
        if key not in self._textures:
            self._textures[key] = board.texture() if pixels_per_square is None else board.texture(pixels_per_square)
        return self.render([Plane(_pose(camera_from_board, "camera_from_board"), self._textures[key], board.extent)])

    # -- the arm scene -------------------------------------------------------------
    def true_base_from_tool(self):
        """The tool pose the virtual arm really has now (true joints: offsets and sag), shape (4, 4) [m].

        Returns
        -------
        ndarray, shape (4, 4)

        Raises
        ------
        OptionError
            The camera is not attached to an arm.
        """
        if self.model is None:
            raise OptionError("expected a VirtualCamera with arm=..., got one without an arm")
        return fk(self.model.robot, self.model.true_q)

    def true_camera_from_markers(self):
        """True poses of every scene marker in the camera frame now: ``{id: camera_from_marker}`` [m].

        Returns
        -------
        dict of int to ndarray, shape (4, 4)
        """
        if self.base_from_camera is None:
            return {}
        camera_from_base = np.linalg.inv(self.base_from_camera)
        out = {k: camera_from_base @ T for k, T in self.base_markers.items()}
        if self.model is not None and self.tool_markers:
            camera_from_tool = camera_from_base @ self.true_base_from_tool()
            out.update({k: camera_from_tool @ T for k, T in self.tool_markers.items()})
        return out

    def capture(self):
        """One frame of the scene: the base markers and the gripper's markers where the arm really is.

        Returns
        -------
        ndarray, shape (height, width), uint8
        """
        return self.render_markers(self.true_camera_from_markers())

    def frames(self, pose_id, count):
        """``count`` frames of the scene now (fresh noise in each); ``pose_id`` is only a label.

        Parameters
        ----------
        pose_id : str
            The pose being measured (a frame source for a folder uses it to find the files).
        count : int
            Number of frames.

        Returns
        -------
        list of ndarray, shape (height, width), uint8
        """
        return [self.capture() for _ in range(int(count))]
