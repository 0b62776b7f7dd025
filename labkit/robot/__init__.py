"""Robot descriptions: Denavit-Hartenberg rows, the frozen :class:`Robot`, robot files.

:mod:`labkit.robot.types` holds the leaf types (Convention, JointType, Link,
ServoCalibration, Gripper, BusServo, Bus) that the kinematics layer uses; the :class:`Robot`
model and the robot-file reader/writer build on them; joint values in display
units (deg, mm), the servos' joint window and a bound of the reach are helpers for labs.
"""

from labkit.robot.types import Convention, JointType, ServoCalibration, Gripper, BusGripper, BusServo, Bus, Link
from labkit.robot._inertia import LinkInertia, Motor
from labkit.robot._model import Robot
from labkit.robot._files import bundled_robots, robot_search_path
from labkit.robot._edit import edit_bus_calibration
from labkit.robot._display import joints_from_display, joints_to_display, servo_travel, servo_window, robot_reach

__all__ = [
    "Convention",
    "JointType",
    "ServoCalibration",
    "Gripper",
    "BusGripper",
    "BusServo",
    "Bus",
    "Link",
    "LinkInertia",
    "Motor",
    "Robot",
    "bundled_robots",
    "robot_search_path",
    "edit_bus_calibration",
    "joints_from_display",
    "joints_to_display",
    "servo_travel",
    "servo_window",
    "robot_reach",
]
