"""The one exception hierarchy of labkit.

Every error labkit raises derives from :class:`LabkitError` and also from the
builtin type callers already catch (``ValueError`` for bad input,
``OSError`` for the device link), the way ``control.exception`` and
``serial.serialutil`` do it.
"""

from __future__ import annotations

__all__ = [
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
    "StorageError",
    "CheckFailed",
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


class StorageError(LabkitError, OSError):
    """Writing a file failed (disk full, I/O error); the message says which file and what to do."""


class CheckFailed(LabkitError, AssertionError):
    """A lab notebook's reproduced number disagrees with the published one beyond its tolerance.

    Derives from ``AssertionError``: a failed check fails the notebook the way a
    failed ``assert`` does.
    """
