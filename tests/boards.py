"""Boards that speak the labkit arm protocol (docs/protocol.md), for the conformance suite.

A *board* is what ``tests/arm/test_protocol_conformance.py`` runs against. Interface
(duck-typed; see :class:`Board`):

- ``open() -> port``: a pyserial-like object (``write``, ``readline``, ``timeout``) on which
  the board has just booted (its ``READY`` line is readable);
- ``pulses() -> {channel: width_us}``: the pulse widths the servos are really commanded now;
- ``pulse_history(since=0.0) -> [(t_s, channel, width_us), ...]``: changes of pulse width in
  board time (for checking trajectories);
- ``set_analog(pin, volts)``: voltage on analog pin 0..5 (A5 = user pot);
- ``reset()``: MCU reset (EEPROM kept; the port stays open and a new ``READY`` follows);
- ``time() -> s`` board time; ``advance(seconds)``: let board time pass (blocking);
- ``close()``.

``BOARDS`` maps a name to a factory; the ``board`` fixture in the suite is parametrised over it.
The firmware board runs the real compiled firmware in simavr, paced to real time so that the
host-silence timeout sees the host's real pauses.
"""

from __future__ import annotations

import serial

from labkit.arm import FirmwareSim


class Board:
    """Interface of a conformance-suite board (documentation only)."""

    name = "abstract"

    def open(self):
        raise NotImplementedError

    def pulses(self) -> dict:
        raise NotImplementedError

    def pulse_history(self, since=0.0) -> list:
        raise NotImplementedError

    def set_analog(self, pin, volts):
        raise NotImplementedError

    def reset(self):
        raise NotImplementedError

    def time(self) -> float:
        raise NotImplementedError

    def advance(self, seconds):
        raise NotImplementedError

    def close(self):
        raise NotImplementedError


class FirmwareBoard(Board):
    """The compiled firmware (firmware/build/labkit_arm.elf) in the simavr harness."""

    name = "firmware"

    def __init__(self, pace=1.0):
        self.sim = FirmwareSim(pace=pace)
        self.port = None

    def open(self):
        self.port = serial.Serial(self.sim.port, 115200, timeout=10.0)
        self.sim.run()  # after opening: pyserial flushed its input on open
        return self.port

    def pulses(self):
        return self.sim.pulses()

    def pulse_history(self, since=0.0):
        self.sim.time()  # barrier
        return [(e.t, e.channel, e.width_us) for e in self.sim.pulse_events(since)]

    def set_analog(self, pin, volts):
        self.sim.set_analog(pin, volts)

    def reset(self):
        self.sim.reset()

    def time(self):
        return self.sim.time()

    def advance(self, seconds):
        self.sim.sleep(seconds)

    def close(self):
        if self.port is not None:
            self.port.close()
        self.sim.close()


BOARDS = {"firmware": FirmwareBoard}


# ---------------------------------------------------------------------------------------------
# Pure-Python virtual arm (labkit.arm) -- section owned by the link engineer.
# Add e.g. ``BOARDS["virtual"] = VirtualBoard`` below.
# ---------------------------------------------------------------------------------------------


class VirtualArmBoard(Board):
    """The pure-Python virtual arm (``labkit.arm``) behind a lockstep ``sim://`` port.

    Board time advances only when the suite waits (``advance``) or blocks in ``readline``,
    so the suite runs as fast as the host can talk, deterministically.
    """

    name = "virtual"

    def __init__(self):
        from labkit.arm.urlhandler import register

        register()
        self.port = None

    def open(self):
        self.port = serial.serial_for_url("sim://arduino_arm_3dof?clock=lockstep&seed=0", timeout=10.0)
        return self.port

    @property
    def _board(self):
        return self.port.board

    def pulses(self):
        return dict(self._board.pulses)

    def pulse_history(self, since=0.0):
        return [e for e in self._board.pulse_log if e[0] >= since]

    def set_analog(self, pin, volts):
        self._board.set_analog(pin, volts)

    def reset(self):
        self._board.reset()

    def time(self):
        return self._board.time

    def advance(self, seconds):
        self.port.sleep(seconds)

    def close(self):
        if self.port is not None:
            self.port.close()


BOARDS["virtual"] = VirtualArmBoard
