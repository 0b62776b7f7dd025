"""The one exception hierarchy of labkit.

Every error labkit raises derives from :class:`LabkitError` and also from the
builtin type callers already catch (``ValueError`` for bad input,
``OSError`` for the device link), the way ``control.exception`` and
``serial.serialutil`` do it. Every exception and warning class of labkit is
defined here; the subpackages that raise them re-export them by name.
"""

from __future__ import annotations

import contextlib

from serial.serialutil import PortNotOpenError, SerialException

__all__ = [
    "EXTRAS",
    "needs_extra",
    "MissingExtraError",
    "LabkitError",
    "ShapeError",
    "OptionError",
    "UnknownBranchError",
    "RotationMatrixError",
    "RobotError",
    "RobotFileError",
    "UnreachableError",
    "JointLimitError",
    "TrajectoryError",
    "DynamicsError",
    "MeasurementError",
    "DeviceError",
    "ProtocolError",
    "CommandRejected",
    "BusFault",
    "BusCalibrationError",
    "PortURLError",
    "PortError",
    "PortClosedError",
    "StorageError",
    "CheckFailed",
    "InvalidSubmission",
    "VisionError",
    "MarkerNotFoundError",
    "WrongMarkerError",
    "AmbiguousPoseError",
    "CalibrationImageError",
    "MeasurementWarning",
    "HandEyeWarning",
    "TorqueWarning",
    "BusWarning",
]


class LabkitError(Exception):
    """Base class of every error raised by labkit."""


class ShapeError(LabkitError, ValueError):
    """An array had the wrong shape, dtype or non-finite values."""


class OptionError(LabkitError, ValueError):
    """An option or argument value is not one of the accepted ones.

    The message lists the valid values and repeats the one received.
    """


class UnknownBranchError(LabkitError, KeyError):
    """An inverse-kinematics branch name that the solver does not have.

    Derives from ``KeyError`` because branches are looked up like keys
    (``solutions["elbow_up"]``); the message lists the valid branch names.
    """

    def __str__(self):
        # KeyError quotes its argument; show the message as written
        return str(self.args[0]) if self.args else ""


class RotationMatrixError(LabkitError, ValueError):
    """A 3x3 matrix is not a proper rotation (not orthonormal or det != +1)."""


class RobotError(LabkitError, ValueError):
    """A robot description (``Link``, ``Robot`` or robot file) is inconsistent.

    The message names the field and says what was expected and what was
    received, with the same wording as the robot-file loader.

    Attributes
    ----------
    field : str or None
        The offending field (``"limits"``, ``"joint[2].type"``, ``"tool"``...).
    """

    def __init__(self, message, field=None):
        self.field = field
        super().__init__(message)


class RobotFileError(RobotError):
    """A robot file is missing, malformed or inconsistent.

    The message names the file, the field and what was expected.
    """

    def __init__(self, path, field, message):
        self.path = str(path)
        super().__init__(f"{self.path}: field '{field}': {message}", field)


class UnreachableError(LabkitError, ValueError):
    """A Cartesian target lies outside the workspace.

    Attributes
    ----------
    distance : float
        How far the target lies outside the reachable set [m] (a lower bound
        where the exact distance is not known in closed form).
    """

    def __init__(self, message, distance=float("nan"), index=None):
        self.distance = float(distance)
        self.index = index
        super().__init__(message)


class JointLimitError(LabkitError, ValueError):
    """A joint value, or every IK solution of a target, violates joint limits.

    Attributes
    ----------
    joint : int
        Index (0-based) of the first offending joint.
    """

    def __init__(self, message, joint=None, index=None):
        self.joint = joint
        self.index = index
        super().__init__(message)


class TrajectoryError(LabkitError, ValueError):
    """A trajectory cannot be built or violates speed/acceleration limits."""


class DynamicsError(LabkitError, ValueError):
    """The dynamics cannot be solved: a singular mass matrix (a joint that moves no mass) or a
    simulation the integrator could not finish."""


class MeasurementError(LabkitError, ValueError):
    """A measurement record or table is malformed (names file, row and column).

    Parameters
    ----------
    message : str
        What was expected and what was received.
    path : str or os.PathLike, optional
        The file the record came from.
    line : int, optional
        The file line of the record (1-based; the header is line 1), stored
        as :attr:`line`; the message calls it a row.
    column : str, optional
        The offending column.

    Attributes
    ----------
    path : str or None
    line : int or None
    column : str or None
    """

    def __init__(self, message, *, path=None, line=None, column=None):
        self.path = None if path is None else str(path)
        self.line = line
        self.column = column
        where = [w for w in (self.path, None if line is None else f"row {line}",
                             None if column is None else f"column '{column}'") if w is not None]
        super().__init__(", ".join(where) + ": " + message if where else message)


class DeviceError(LabkitError, OSError):
    """The link to the arm failed: timeout, garbled reply, vanished port."""


class ProtocolError(DeviceError):
    """The board answered, but not with a valid protocol reply."""


class CommandRejected(DeviceError):
    """The board answered ``ERR``: the request had no effect.

    Parameters
    ----------
    message : str
        What was asked and why the board refused.
    code : int
        Error code (key of :data:`labkit.arm.ERRORS`).
    name : str
        Its name as the board sent it (``"LIMIT"``, ``"QFULL"`` ...).

    Attributes
    ----------
    code : int
    name : str
    """

    def __init__(self, message, code, name):
        self.code = code
        self.name = name
        super().__init__(message)


class BusFault(DeviceError):
    """A servo bus failed: a servo silent or its status packet corrupt, or a servo in hardware error.

    The arm is stopped and every servo's torque turned off before it is raised.
    """


class BusCalibrationError(LabkitError, ValueError):
    """A guided servo-bus calibration cannot finish: a joint did not move as asked, its range does not fit
    the servo's one turn, or a homing offset is out of the servo's range; the message says what to redo."""


class PortURLError(OptionError, SerialException):
    """A ``sim://`` or ``simavr://`` URL that cannot be opened: another scheme, an unknown option, a bad value.

    An :class:`OptionError` (the message names the option, what was expected and what
    was received) that is also pyserial's ``SerialException``, which callers of
    ``serial.serial_for_url`` catch.
    """


class PortError(DeviceError, SerialException):
    """A simulated port failed: its board or simulator could not be started, or a read cannot return.

    A :class:`DeviceError` that is also pyserial's ``SerialException``.
    """


class PortClosedError(PortError, PortNotOpenError):
    """A closed ``sim://`` port was used (also pyserial's ``PortNotOpenError``).

    Parameters
    ----------
    port : str
        The port's URL.
    """

    def __init__(self, port):
        SerialException.__init__(self, f"{port}: expected an open port, got a closed one (open it first)")


class StorageError(LabkitError, OSError):
    """Writing a file failed (disk full, I/O error); the message says which file and what to do."""


class CheckFailed(LabkitError, AssertionError):
    """A lab notebook's reproduced number disagrees with the published one beyond its tolerance.

    Derives from ``AssertionError``: a failed check fails the notebook the way a
    failed ``assert`` does.
    """


class InvalidSubmission(LabkitError, ValueError):
    """A student's notebook is not one labkit can grade (not a file, not a notebook, a malformed cell)."""


class VisionError(LabkitError, ValueError):
    """An image, a camera model or a calibration input is not what was expected."""


class MarkerNotFoundError(VisionError):
    """No marker of the expected family was detected in an image."""


class WrongMarkerError(VisionError):
    """Markers were detected, but not the one (or ones) asked for."""


class AmbiguousPoseError(VisionError):
    """The two pose solutions of a square marker (IPPE) fit the corners about equally well.

    The marker is seen too nearly face-on, too small or too blurred for its tilt to be
    known; tilt the marker (or the camera) by 20 deg or more, or move closer.
    """


class CalibrationImageError(VisionError):
    """A calibration board was found in too few images to calibrate the camera."""


class MeasurementWarning(UserWarning):
    """A torn (crash-truncated) line was skipped while loading measurements."""


class BusWarning(UserWarning):
    """A servo bus opened with a setting likely to lose status packets (an adapter latency timer too long)."""


class HandEyeWarning(UserWarning):
    """The views of a hand-eye calibration are too alike for a trustworthy result."""


class TorqueWarning(UserWarning):
    """A motion plan asks a joint for more torque than its servo's stall torque gives."""


class MissingExtraError(LabkitError, ImportError):
    """A feature needs a module from one of labkit's extras, and that extra is not installed.

    The message names the module and the command that installs it (``pip install 'labkit[reports]'``).
    """


#: labkit's extras (pyproject.toml's optional dependencies) that a feature can need: ``pip install 'labkit[NAME]'``
EXTRAS = ("reports", "lab", "course", "vision", "bus", "urdf")


@contextlib.contextmanager
def needs_extra(extra):
    """Import an extra's modules inside this block; a missing one raises :class:`MissingExtraError`.

    The core (``pip install labkit``) brings what the math, motion, measurement tables, plots and
    the serial link need; notebooks and reports, JupyterLab, the course tools, the camera, the
    servo buses and URDF import come with extras. Every import of an extra's module in labkit
    sits in such a block (``tests/test_packaging.py`` checks it, and that the extra declares the
    module's distribution), so a missing one says which ``pip install`` to run instead of a bare
    ``ModuleNotFoundError``.

    Parameters
    ----------
    extra : str
        One of :data:`EXTRAS`.

    Yields
    ------
    None
        The block runs once.

    Raises
    ------
    MissingExtraError
        A module imported in the block is not installed.
    OptionError
        ``extra`` is not one of :data:`EXTRAS`.

    Examples
    --------
    >>> with needs_extra("vision"):
    ...     import not_a_module_labkit_has  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    labkit.exceptions.MissingExtraError: this needs the module 'not_a_module_labkit_has', which labkit's 'vision' extra brings and which is not installed: pip install 'labkit[vision]'
    """
    if extra not in EXTRAS:
        raise OptionError(f"unknown labkit extra {extra!r}; expected one of {', '.join(EXTRAS)}")
    try:
        yield
    except ModuleNotFoundError as exc:
        raise MissingExtraError(f"this needs the module {exc.name!r}, which labkit's {extra!r} extra brings and "
                                f"which is not installed: pip install 'labkit[{extra}]'", name=exc.name) from exc
