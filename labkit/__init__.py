"""labkit: a lab-report notebook and plotting workbench for robotics courses.

Import what you need from the subpackages, one per concept: ``labkit.robot``
(DH rows, Robot, robot files), ``labkit.rotations``, ``labkit.kinematics``,
``labkit.motion``, ``labkit.plotting``, ``labkit.measure``, ``labkit.arm``,
``labkit.reports`` and ``labkit.cli`` (layers and dependency rule:
``docs/architecture.md``). The top level re-exports the exceptions and the
robot model; the robot names load on first use, so ``import labkit`` stays light.

Examples
--------
>>> import labkit
>>> labkit.Robot.load("planar3r_seed004").n
3
"""

from labkit.exceptions import (
    CheckFailed,
    DeviceError,
    JointLimitError,
    LabkitError,
    MeasurementError,
    OptionError,
    ProtocolError,
    RobotError,
    StorageError,
    RobotFileError,
    RotationMatrixError,
    ShapeError,
    TrajectoryError,
    UnknownBranchError,
    UnreachableError,
)

__version__ = "0.1.0"

#: names re-exported from labkit.robot, imported when first asked for (PEP 562)
_ROBOT_NAMES = ("Convention", "JointType", "Link", "Robot", "bundled_robots")

__all__ = [
    *_ROBOT_NAMES,
    "CheckFailed",
    "DeviceError",
    "JointLimitError",
    "LabkitError",
    "MeasurementError",
    "OptionError",
    "ProtocolError",
    "RobotError",
    "StorageError",
    "RobotFileError",
    "RotationMatrixError",
    "ShapeError",
    "TrajectoryError",
    "UnknownBranchError",
    "UnreachableError",
]


def __getattr__(name):
    if name in _ROBOT_NAMES:
        from labkit import robot

        return getattr(robot, name)
    raise AttributeError(f"module 'labkit' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_ROBOT_NAMES))
