"""Robot descriptions: Denavit-Hartenberg rows, the frozen :class:`Robot`, robot files.

:mod:`labkit.robot.types` holds the leaf types (Convention, JointType, Link,
ServoCalibration, Gripper) that the kinematics layer uses; the :class:`Robot`
model and the robot-file reader/writer build on them.
"""

from labkit.robot.types import Convention, JointType, ServoCalibration, Gripper, Link
from labkit.robot._model import Robot
from labkit.robot._files import bundled_robots, robot_search_path

__all__ = [
    "Convention",
    "JointType",
    "ServoCalibration",
    "Gripper",
    "Link",
    "Robot",
    "bundled_robots",
    "robot_search_path",
]
