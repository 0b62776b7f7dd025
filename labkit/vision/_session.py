"""Measurement sessions with a camera (:class:`CameraSession`) and frame sources.

A session moves the arm through a plan of poses (:class:`labkit.measure.PlannedPose`),
takes several frames at each pose, finds the camera in the base frame from the
reference markers, the gripper's markers in the camera frame, and logs the tool
point in the base frame into the crash-safe :class:`labkit.measure.MeasurementLog`:
the same schema as ruler readings (quantities x, y, z in mm, ``instrument =
"camera"``), with each reading's own uncertainty in the ``resolution`` column
(``coverage`` standard uncertainties, the camera location's included). The
error tables, the audit and the calibration of :mod:`labkit.measure` read it
unchanged.

Frame sources have one method, ``frames(pose_id, count) -> list of images``:
:class:`VirtualCamera` (``sim://``), :class:`VideoSource` (a webcam through
``cv2.VideoCapture``) and :class:`FolderSource` (images saved earlier, found by
pose id, so a missing image never shifts the pairing).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from labkit.exceptions import DeviceError, OptionError, needs_extra
from labkit.measure import MeasurementSession
from labkit.validation import as_count, as_number, as_path
from labkit.exceptions import MarkerNotFoundError, VisionError, WrongMarkerError
from labkit.vision._camera import Camera
from labkit.vision._locate import locate_camera
from labkit.vision._markers import MIN_BIT_WIDTH, marker_poses
from labkit.vision._rig import CameraRig

__all__ = ["CameraSession", "VideoSource", "FolderSource", "tool_point_in_base"]

_IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


class VideoSource:
    """Frames from a webcam, a video stream or a video file (``cv2.VideoCapture``).

    A webcam keeps a queue of frames it took earlier (OpenCV's V4L2 backend holds 4 by
    default and stops filling it while it is full), so after the arm moves the first
    frames read still show it where it was. :meth:`frames` therefore drops the queued
    frames (``stale``, grabbed without decoding) and ``warmup`` more (auto exposure
    settles) before it keeps ``count`` fresh ones.

    Parameters
    ----------
    device : int or str or os.PathLike
        Camera index (0: the first webcam), a stream URL (``http://.../video.mjpg``,
        ``rtsp://...``) or a video file.
    width, height : int, optional
        Requested resolution [px]; a device that delivers another one raises.
    stale : int, optional
        Frames the device queues. Default: ask the backend for a one-frame queue
        (``CAP_PROP_BUFFERSIZE``) and take the length it reports, 4 (the V4L2 default) if it
        reports none; 0 for a video file (its frames are not taken live).
    warmup : int
        Frames dropped after the queued ones, at each pose.
    retries : int
        Failed reads in a row tolerated at a pose (a webcam drops a frame now and then).

    Raises
    ------
    DeviceError
        The device cannot be opened, or it delivers another resolution than requested.
    OptionError
        A device that is neither a camera index nor a path; a size, stale, warmup or retries that is not a whole
        number in range.

    Attributes
    ----------
    dropped : int
        Failed reads so far (each one retried).
    """

    def __init__(self, device=0, *, width=None, height=None, stale=None, warmup=3, retries=2):
        with needs_extra("vision"):
            import cv2

        warmup, retries = as_count(warmup, "warmup"), as_count(retries, "retries")
        stale = None if stale is None else as_count(stale, "stale")
        width, height = (None if v is None else as_count(v, name, minimum=1) for v, name in ((width, "width"),
                                                                                          (height, "height")))
        if isinstance(device, os.PathLike):
            device = os.fspath(device)
        if not (isinstance(device, str) and device):
            device = as_count(device, "device (a camera index or a path)")
        self.device = device
        is_file = not isinstance(device, int) and Path(device).is_file()
        self.capture = cv2.VideoCapture(str(device) if is_file else device)
        if not self.capture.isOpened():
            raise DeviceError(f"expected a camera, stream or video at {device!r}, cv2.VideoCapture could not open it")
        if width:
            self.capture.set(cv2.CAP_PROP_FRAME_WIDTH, int(width))
        if height:
            self.capture.set(cv2.CAP_PROP_FRAME_HEIGHT, int(height))
        size = (int(self.capture.get(cv2.CAP_PROP_FRAME_WIDTH)), int(self.capture.get(cv2.CAP_PROP_FRAME_HEIGHT)))
        if (width and size[0] != int(width)) or (height and size[1] != int(height)):
            self.capture.release()
            raise DeviceError(f"expected {width}x{height} frames from {device!r}, it delivers {size[0]}x{size[1]}")
        if stale is None:
            if is_file:
                stale = 0
            else:
                self.capture.set(cv2.CAP_PROP_BUFFERSIZE, 1)
                queued = int(self.capture.get(cv2.CAP_PROP_BUFFERSIZE))
                stale = queued if queued > 0 else 4
        self.stale, self.warmup, self.retries = int(stale), int(warmup), int(retries)
        self.dropped = 0

    def _next(self, decode):
        for _ in range(self.retries + 1):
            if decode:
                ok, frame = self.capture.read()
                ok = ok and frame is not None
            else:
                ok, frame = self.capture.grab(), None
            if ok:
                return True, frame
            self.dropped += 1
        return False, None

    def frames(self, pose_id, count):
        """``count`` fresh frames, after dropping ``stale`` queued and ``warmup`` frames.

        Parameters
        ----------
        pose_id : str
            The pose being measured (a label in messages).
        count : int
            Frames to keep.

        Returns
        -------
        list of ndarray, shape (height, width, 3), uint8
            BGR images.

        Raises
        ------
        DeviceError
            The device gave no frame ``retries + 1`` times in a row (end of the stream, or the
            camera dropped out); the message says how many frames it gave at this pose.
        """
        if not self.capture.isOpened():
            raise DeviceError(f"pose {pose_id!r}: expected an open camera at {self.device!r}, it was closed")
        skip = self.stale + self.warmup
        for k in range(skip):
            if not self._next(decode=False)[0]:
                raise DeviceError(f"pose {pose_id!r}: {self.device!r} gave no frame after {k} of the {skip} dropped "
                                  f"before a capture ({self.stale} queued + {self.warmup} warm-up): end of the stream "
                                  "or the camera dropped out")
        out = []
        for k in range(int(count)):
            ok, frame = self._next(decode=True)
            if not ok:
                raise DeviceError(f"pose {pose_id!r}: expected {int(count)} frames from {self.device!r}, got {k} "
                                  f"({self.retries + 1} failed reads in a row): end of the stream or the camera dropped out")
            out.append(frame)
        return out

    def close(self):
        """Release the camera."""
        self.capture.release()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class FolderSource:
    """Frames saved earlier in a folder, named ``<pose_id>_<k>.png`` (or ``.jpg`` ...).

    Parameters
    ----------
    folder : str or os.PathLike
    """

    def __init__(self, folder):
        self.folder = as_path(folder, "a folder of images", error=VisionError)
        if not self.folder.is_dir():
            raise VisionError(f"expected a folder of images, got {self.folder}")

    def paths(self, pose_id):
        """The image files of one pose, in name order.

        Parameters
        ----------
        pose_id : str

        Returns
        -------
        list of pathlib.Path
        """
        if not (isinstance(pose_id, str) and pose_id):
            raise VisionError(f"expected pose_id as the text the image names start with, got {pose_id!r}")
        return sorted(p for p in self.folder.glob(f"{pose_id}_*") if p.suffix.lower() in _IMAGE_SUFFIXES
                      and p.stem[len(pose_id) + 1:].isdigit())

    def frames(self, pose_id, count):
        """Up to ``count`` images of one pose.

        Parameters
        ----------
        pose_id : str
        count : int

        Returns
        -------
        list of ndarray

        Raises
        ------
        VisionError
            No image of that pose.
        """
        with needs_extra("vision"):
            import cv2

        paths = self.paths(pose_id)[: as_count(count, "count", minimum=1)]
        if not paths:
            raise VisionError(f"expected images {pose_id}_<k>.png in {self.folder}, found none")
        return [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in paths]


def tool_point_in_base(detections, location, tool_markers, tool_point=(0.0, 0.0, 0.0)):
    """The tool point in the base frame from the gripper's markers in one frame, with its covariance.

    Markers with an ambiguous pose, or seen so obliquely that a bit is narrower than
    ``MIN_BIT_WIDTH`` across a side, are left out; several markers are combined by
    inverse-covariance weighting (their errors are taken as independent; the camera
    location's part, common to all, is added once).

    Parameters
    ----------
    detections : sequence of MarkerDetection
    location : CameraLocation
    tool_markers : mapping
        ``{id: tool_from_marker}`` [m].
    tool_point : array_like, shape (3,)
        The point to measure, in the tool frame [m].

    Returns
    -------
    position : ndarray, shape (3,)
        [m], base frame.
    covariance : ndarray, shape (3, 3)
        [m^2].
    used : list of int
        Ids of the markers used.

    Raises
    ------
    WrongMarkerError
        None of the gripper's markers was seen with a clear pose.
    """
    estimates = []
    for d in detections:
        if d.id not in tool_markers or d.ambiguous or d.bit_width < MIN_BIT_WIDTH:
            continue
        marker_from_tool = np.linalg.inv(tool_markers[d.id])
        point = marker_from_tool[:3, :3] @ np.asarray(tool_point, float) + marker_from_tool[:3, 3]
        p_cam, cov_cam = d.point_covariance(point)
        estimates.append((d.id, p_cam, cov_cam))
    if not estimates:
        seen = sorted(d.id for d in detections)
        raise WrongMarkerError(f"expected a clear view of gripper marker(s) {sorted(tool_markers)}, "
                               f"saw {seen} (ambiguous ones and ones seen nearly edge-on left out)")
    info = sum(np.linalg.inv(c) for _, _, c in estimates)
    cov_cam = np.linalg.inv(info)
    p_cam = cov_cam @ sum(np.linalg.inv(c) @ p for _, p, c in estimates)
    p_base, cov_base = location.to_base(p_cam, cov_cam)
    return p_base, cov_base, [i for i, _, _ in estimates]


class CameraSession:
    """Measure a plan of poses with a camera and log the tool point like ruler readings.

    Parameters
    ----------
    arm : labkit.arm.Arm
    log : MeasurementLog or str or os.PathLike
    source : frame source
        An object with ``frames(pose_id, count)``: :class:`VirtualCamera`,
        :class:`VideoSource` or :class:`FolderSource`.
    rig : CameraRig
        The markers (gripper and reference), their sizes and family; ``rig.camera`` unless
        ``camera`` is given.
    camera : Camera, optional
        The calibrated camera (default ``rig.camera``).
    frames : int
        Frames per pose (each one a reading).
    coverage : float
        Coverage factor of the logged uncertainty (2: about 95 %).
    settle_tol, settle_time : float
        As for :class:`labkit.measure.MeasurementSession` [rad], [s].
    operator : str
    """

    def __init__(self, arm, log, source, rig, *, camera=None, frames=5, coverage=2.0,
                 settle_tol=math.radians(1.0), settle_time=0.5, operator=""):
        frames = as_count(frames, "frames", minimum=1)
        coverage = as_number(coverage, "coverage", positive=True)
        if not hasattr(source, "frames"):
            raise OptionError(f"expected source as a frame source (VideoSource, FolderSource, a VirtualCamera), "
                              f"got {source!r}")
        if not isinstance(rig, CameraRig):
            raise OptionError(f"expected rig as a CameraRig, got {rig!r}")
        if camera is not None and not isinstance(camera, Camera):
            raise OptionError(f"expected camera as a labkit.vision.Camera or None, got {camera!r}")
        self._moves = MeasurementSession(arm, log, source="feedback", readings=1, settle_tol=settle_tol,
                                         settle_time=settle_time, operator=operator)
        self.arm = arm
        self.log = self._moves.log
        self.source = source
        self.rig = rig
        self.camera = rig.camera if camera is None else camera
        self.frames = int(frames)
        self.coverage = float(coverage)
        self.skipped = {}

    def detect(self, images):
        """Detections of every frame (frames without a marker give an empty list).

        Parameters
        ----------
        images : sequence of ndarray

        Returns
        -------
        list of list of MarkerDetection
        """
        out = []
        for img in images:
            try:
                out.append(marker_poses(img, self.camera, self.rig.size, self.rig.family,
                                        ids=sorted(self.rig.size), on_ambiguous="keep"))
            except (MarkerNotFoundError, WrongMarkerError):
                out.append([])
        return out

    def measure(self, pose):
        """Move to a pose, take the frames, log x, y, z [mm] of the tool point per frame.

        Parameters
        ----------
        pose : PlannedPose

        Returns
        -------
        list of MeasurementRecord

        Raises
        ------
        VisionError
            A frame of another size than the camera's ``image_size``.
        MarkerNotFoundError
            No reference marker in any frame (the camera cannot be located).
        WrongMarkerError
            No frame had a clear view of a gripper marker.
        """
        q = np.asarray(pose.q, dtype=float)
        self._moves.goto(q)
        images = self.source.frames(pose.pose_id, self.frames)
        size = self.camera.image_size
        wrong = [np.shape(img)[1::-1] for img in images if size is not None and tuple(np.shape(img)[1::-1]) != tuple(size)]
        if wrong:
            raise VisionError(f"pose {pose.pose_id!r}: expected {size[0]}x{size[1]} frames (the calibrated camera's), "
                              f"got {wrong[0][0]}x{wrong[0][1]}")
        frames = self.detect(images)
        location = locate_camera(frames, self.rig.base_markers, self.camera)
        records, failures = [], []
        for k, dets in enumerate(frames):
            try:
                p, cov, used = tool_point_in_base(dets, location, self.rig.tool_markers)
            except WrongMarkerError as exc:
                failures.append(str(exc))
                continue
            u = self.coverage * np.sqrt(np.diag(cov))
            note = f"camera k={self.coverage:g}; markers {','.join(map(str, used))}; frame {k + 1}/{len(frames)}"
            for axis, v, uu in zip("xyz", p * 1e3, u * 1e3):
                records.append(self.log.record(pose.pose_id, axis, float(v), unit="mm", instrument="camera",
                                               resolution=float(max(uu, 1e-3)), commanded=q, note=note))
        if failures:
            self.skipped[pose.pose_id] = len(failures)
        if not records:
            raise WrongMarkerError(f"pose {pose.pose_id!r}: no frame gave a gripper position ({failures[0]})")
        return records

    def run(self, plan, *, progress=None):
        """Measure every pose of a plan; returns the session's readings.

        Parameters
        ----------
        plan : sequence of PlannedPose
        progress : callable, optional
            ``progress(done, total, pose_id)`` after each pose.

        Returns
        -------
        pandas.DataFrame
            ``log.to_dataframe()``.
        """
        for k, pose in enumerate(plan):
            self.measure(pose)
            if progress is not None:
                progress(k + 1, len(plan), pose.pose_id)
        return self.log.to_dataframe()
