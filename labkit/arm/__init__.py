"""The arm, in three parts around one protocol module:

- :mod:`labkit.arm.link`: the host link (:class:`Arm`), what a notebook uses;
- :mod:`labkit.arm.board`: the virtual board and its physics (``sim://``);
- :mod:`labkit.arm.simavr`: the real firmware in the AVR simulator (``simavr://``);

plus what the host needs of any board (:class:`BoardPort`, the one interface :class:`Arm` uses),
the protocol shared by host and boards (framing, checksums, codes), the integer
segment check the firmware, the virtual board and the host all run, fault injection
for tests, and the pyserial URL handlers (:mod:`labkit.arm.urlhandler`).
"""

from labkit.arm._protocol import (checksum, CommandRejected, PROTOCOL_VERSION, MAX_LINE, MAX_JOINTS, ERRORS, WireUnits,
                                  max_joints, check_joint_count)
from labkit.arm._board_port import BoardPort
from labkit.arm.link import BoardInfo, Status, LinkStats, TrajectoryReport, segments_from_trajectory, ArduinoPort, PortInfo, list_ports, find_ports, Arm, settle_tolerance, calibrate_bus
from labkit.arm.board import PhysicsConfig, ServoBank, gravity_sag, ADC_VREF, ADC_MAX, ArmModel, FirmwareAdapter, FW_VERSION, Executor, Servos, VirtualBoard, make_board, serve_pty
from labkit.arm.simavr import FIRMWARE_DIR, FirmwareSim, PulseEvent, build, default_elf, harness_path, SimavrPort
from labkit.exceptions import PortURLError, PortError, PortClosedError
from labkit.arm._faults import PortWrapper, FaultConfig, FaultyPort, Direction
from labkit.arm._actuator import is_ideal, ideal_speed_limits

__all__ = [
    "checksum",
    "CommandRejected",
    "PROTOCOL_VERSION",
    "MAX_LINE",
    "MAX_JOINTS",
    "max_joints",
    "check_joint_count",
    "ERRORS",
    "WireUnits",
    "BoardPort",
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
    "PhysicsConfig",
    "ServoBank",
    "gravity_sag",
    "ADC_VREF",
    "ADC_MAX",
    "ArmModel",
    "FirmwareAdapter",
    "FW_VERSION",
    "Executor",
    "Servos",
    "VirtualBoard",
    "make_board",
    "serve_pty",
    "FIRMWARE_DIR",
    "FirmwareSim",
    "PulseEvent",
    "build",
    "default_elf",
    "harness_path",
    "SimavrPort",
    "PortURLError",
    "PortError",
    "PortClosedError",
    "PortWrapper",
    "FaultConfig",
    "FaultyPort",
    "Direction",
    "is_ideal",
    "ideal_speed_limits",
]
