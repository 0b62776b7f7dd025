"""The host side of the link: :class:`Arm` (motion commands checked against the robot
file before anything is sent, read-back, streaming), the wire (framing, sequence ids,
retries, board time), board replies, serial ports (a real board's as an :class:`ArduinoPort`), and
trajectories cut into the board's segments. The host reaches every board through one interface,
:class:`labkit.arm.BoardPort`.
"""

from labkit.arm.link._replies import BoardInfo, Status
from labkit.arm.link._wire import LinkStats
from labkit.arm.link._segments import TrajectoryReport, segments_from_trajectory
from labkit.arm.link._ports import ArduinoPort, PortInfo, list_ports, find_ports
from labkit.arm.link._arm import Arm
from labkit.arm.link._feedback import settle_tolerance
from labkit.arm.link._calibrate import calibrate_bus

__all__ = [
    "BoardInfo",
    "Status",
    "LinkStats",
    "TrajectoryReport",
    "segments_from_trajectory",
    "ArduinoPort",
    "PortInfo",
    "list_ports",
    "find_ports",
    "Arm",
    "settle_tolerance",
    "calibrate_bus",
]
