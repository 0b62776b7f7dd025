"""Measuring with a camera: the camera model and its calibration, marker poses, camera-to-robot
(hand-eye) calibration, measurement sessions with a camera, and a virtual camera for ``sim://``.

See ``docs/camera.md``. Lengths in m, angles in rad, image coordinates in px.
"""

from labkit.exceptions import (
    VisionError,
    MarkerNotFoundError,
    WrongMarkerError,
    AmbiguousPoseError,
    CalibrationImageError,
    HandEyeWarning,
)
from labkit.vision._camera import Camera, CameraCalibration, calibrate_camera
from labkit.vision._families import FAMILIES, MarkerFamily, family_info, marker_texture
from labkit.vision._markers import MarkerDetection, marker_poses, detect_markers, marker_corners
from labkit.vision._boards import Checkerboard, CharucoBoard
from labkit.vision._render import Plane
from labkit.vision._virtual import VirtualCamera
from labkit.vision._locate import CameraLocation, locate_camera
from labkit.vision._rig import CameraRig, look_at, face_marker
from labkit.vision._handeye import HandEyeResult, hand_eye, rotation_spread, STARTS
from labkit.vision._sheets import marker_sheet, board_sheet
from labkit.vision._session import CameraSession, VideoSource, FolderSource, tool_point_in_base

__all__ = [
    "VisionError",
    "MarkerNotFoundError",
    "WrongMarkerError",
    "AmbiguousPoseError",
    "CalibrationImageError",
    "HandEyeWarning",
    "Camera",
    "FAMILIES",
    "MarkerFamily",
    "family_info",
    "marker_texture",
    "MarkerDetection",
    "marker_poses",
    "detect_markers",
    "marker_corners",
    "Checkerboard",
    "CharucoBoard",
    "Plane",
    "VirtualCamera",
    "CameraLocation",
    "locate_camera",
    "CameraRig",
    "look_at",
    "face_marker",
    "CameraCalibration",
    "calibrate_camera",
    "HandEyeResult",
    "hand_eye",
    "rotation_spread",
    "STARTS",
    "marker_sheet",
    "board_sheet",
    "CameraSession",
    "VideoSource",
    "FolderSource",
    "tool_point_in_base",
]
