"""The arm: the serial protocol shared by host and virtual board, the host link
(:class:`Arm`), the virtual board and its physics, the firmware in simavr, fault
injection and the ``sim://`` / ``simavr://`` URL handlers.
"""

from labkit.arm._protocol import checksum, CommandRejected, PROTOCOL_VERSION, MAX_LINE, ERRORS
from labkit.arm._replies import BoardInfo, Status
from labkit.arm._wire import LinkStats
from labkit.arm._segments import TrajectoryReport, segments_from_trajectory
from labkit.arm._ports import PortInfo, list_ports, find_ports
from labkit.arm._link import Arm
from labkit.arm._physics import PhysicsConfig, ServoBank, gravity_sag, ADC_VREF, ADC_MAX
from labkit.arm._model import ArmModel, FirmwareAdapter
from labkit.arm._commands import FW_VERSION
from labkit.arm._board import VirtualBoard
from labkit.arm._pty import make_board, serve_pty
from labkit.arm._firmware import FIRMWARE_DIR, FirmwareSim, PulseEvent, build, default_elf, harness_path
from labkit.arm._simavr_port import SimavrPort
from labkit.arm._faults import PortWrapper, FaultConfig, FaultyPort, Direction

__all__ = [
    "checksum",
    "CommandRejected",
    "PROTOCOL_VERSION",
    "MAX_LINE",
    "ERRORS",
    "BoardInfo",
    "Status",
    "LinkStats",
    "TrajectoryReport",
    "segments_from_trajectory",
    "Arm",
    "find_ports",
    "list_ports",
    "PortInfo",
    "PhysicsConfig",
    "ServoBank",
    "gravity_sag",
    "ADC_VREF",
    "ADC_MAX",
    "ArmModel",
    "FirmwareAdapter",
    "FW_VERSION",
    "VirtualBoard",
    "make_board",
    "serve_pty",
    "FIRMWARE_DIR",
    "FirmwareSim",
    "SimavrPort",
    "PulseEvent",
    "build",
    "default_elf",
    "harness_path",
    "PortWrapper",
    "FaultConfig",
    "FaultyPort",
    "Direction",
]
