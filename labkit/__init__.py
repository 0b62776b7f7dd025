"""labkit: a lab-report notebook and plotting workbench for robotics courses.

Import what you need from the concept modules (``labkit.kinematics``,
``labkit.ik``, ``labkit.trajectory`` ...); the top level re-exports only the
robot model and the exceptions so that ``import labkit`` stays light.
"""

from labkit.dh import Convention, JointType, Link, Robot, bundled_robots
from labkit.exceptions import (
    DeviceError,
    JointLimitError,
    LabkitError,
    MeasurementError,
    ProtocolError,
    RobotFileError,
    ShapeError,
    TrajectoryError,
    UnreachableError,
)

__version__ = "0.1.0"

__all__ = [
    "Convention",
    "JointType",
    "Link",
    "Robot",
    "bundled_robots",
    "DeviceError",
    "JointLimitError",
    "LabkitError",
    "MeasurementError",
    "ProtocolError",
    "RobotFileError",
    "ShapeError",
    "TrajectoryError",
    "UnreachableError",
]
