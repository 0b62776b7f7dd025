"""Smart-servo buses behind :class:`labkit.arm.Arm`: Dynamixel Protocol 2.0 and Feetech STS, one codec module each.

:class:`BusBoard` is a host-side board: it speaks labkit's protocol to :class:`~labkit.arm.Arm`
through the board's :class:`~labkit.arm.board.Executor`, which it holds (the command set and segment
executor every in-process board holds), and drives the servos through the vendor SDK
(``dynamixel-sdk``, ``feetech-servo-sdk``); :class:`BusEmulator` is a virtual bus on a
pseudo-terminal that the unmodified SDKs talk to. The bus protocols are a registry, :data:`BUSES`
(protocol -> codec module): a new protocol is one module and one entry. URLs: ``dynamixel:///dev/ttyUSB0``,
``feetech:///dev/ttyACM0``, ``sim://<robot>?bus=dynamixel`` (``docs/link.md``). :func:`calibrate_servos` guides a
student through each joint with torque off (zero mark, a move towards +, stop to stop) and computes the
robot file's ``bus`` zeros, directions and limits; the virtual buses emulate the mounting
(:class:`VirtualServo`) and the hand (:class:`VirtualHand`).
"""

from labkit.arm.bus._driver import BusFault, BusReading, BusDriver
from labkit.arm.bus._registry import BUSES, bus_module
from labkit.arm.bus._emulator import BusEmulator, BusFaults
from labkit.arm.bus._board import BusBoard, open_bus_board
from labkit.arm.bus._stream import record_bus_stream
from labkit.arm.bus._gains import ServoGains, GainBook
from labkit.arm.bus._gripper import GripperState, GripperServo, VirtualGripper, limit_register
from labkit.arm.bus._servo_loop import LoopPlant, loop_plant, position_loop, PositionLoops
from labkit.arm.bus._hardware import VirtualServo, VirtualHand, assembled_servos
from labkit.arm.bus._calibrate import (CalibrationStep, JointBusCalibration, BusCalibration, unwrap_ticks,
                                       solve_joint, calibrate_servos)

__all__ = [
    "BusFault",
    "BusReading",
    "BusDriver",
    "BUSES",
    "bus_module",
    "BusEmulator",
    "BusFaults",
    "BusBoard",
    "open_bus_board",
    "record_bus_stream",
    "ServoGains",
    "GripperState",
    "GripperServo",
    "VirtualGripper",
    "limit_register",
    "GainBook",
    "LoopPlant",
    "loop_plant",
    "position_loop",
    "PositionLoops",
    "VirtualServo",
    "VirtualHand",
    "assembled_servos",
    "CalibrationStep",
    "JointBusCalibration",
    "BusCalibration",
    "unwrap_ticks",
    "solve_joint",
    "calibrate_servos",
]
