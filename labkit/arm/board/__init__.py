"""The virtual board: the firmware's commands in Python (:class:`Executor`, the same
checks and replies as the firmware, held by every in-process board), hobby servos and the
arm they drive (:class:`VirtualBoard`, :class:`ArmModel`: servo lag, speed limits, gravity
sag, zero offsets, sensor noise) and a pseudo-terminal that serves it to any serial program.
"""

from labkit.arm.board._physics import PhysicsConfig, ServoBank, gravity_sag, point_mass_links, ADC_VREF, ADC_MAX
from labkit.arm.board._model import ArmModel, FirmwareAdapter
from labkit.arm.board._commands import FW_VERSION
from labkit.arm.board._executor import Executor, Servos
from labkit.arm.board._board import VirtualBoard
from labkit.arm.board._pty import make_board, serve_pty

__all__ = [
    "PhysicsConfig",
    "ServoBank",
    "gravity_sag",
    "point_mass_links",
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
]
