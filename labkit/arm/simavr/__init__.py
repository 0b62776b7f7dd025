"""The real firmware in the AVR simulator: building the sketch, the simavr harness
(:class:`FirmwareSim`, free-running, paced or stepped in board time) and a serial
port on it (:class:`SimavrPort`).
"""

from labkit.arm.simavr._firmware import FIRMWARE_DIR, FirmwareSim, PulseEvent, build, default_elf, harness_path
from labkit.arm.simavr._simavr_port import CLOCKS, SimavrPort

__all__ = [
    "FIRMWARE_DIR",
    "FirmwareSim",
    "PulseEvent",
    "build",
    "default_elf",
    "harness_path",
    "CLOCKS",
    "SimavrPort",
]
