"""The firmware in simavr runs on board time: ``simavr://`` (``clock=lockstep``) and :class:`SimavrPort`.

In lockstep the simulated CPU runs only while the host waits, so a host that stalls on the wall clock
(a loaded machine, a descheduled process) changes nothing the board sees: the same requests give the
same board times, and the firmware's host-silence timer (500 ms of board time) never trips because
of the host machine.
"""

import math
import time

import numpy as np
import pytest
import serial

from labkit.arm import Arm, FirmwareSim, PortWrapper, SimavrPort
from labkit.arm.urlhandler import register
from labkit.exceptions import DeviceError, OptionError

register()
pytestmark = [pytest.mark.firmware, pytest.mark.xdist_group("firmware")]


class Stalling(PortWrapper):
    """Every read first sleeps ``seconds`` of wall-clock time: a host the machine keeps descheduling."""

    def __init__(self, port):
        super().__init__(port)
        self.seconds = 0.0
        self.stalls = 0

    def read(self, size=1):
        if self.seconds:
            time.sleep(self.seconds)
            self.stalls += 1
        return self._port.read(size)


def _timed_move(stall_s):
    port = serial.serial_for_url("simavr://", baudrate=115200, timeout=0.05)
    stalling = Stalling(port)
    with Arm("arduino_arm_3dof", stalling, timeout=0.05) as arm:
        stalling.seconds = stall_s
        arm.move_joints(np.radians([30.0, 60.0, 120.0]), duration=1.0)  # STATUS polled every 50 ms of board time
        stalling.seconds = 0.0
        board_ms = arm.ping()
        st = arm.status()
        events = list(arm.events)
    return board_ms, st, events, stalling.stalls


def test_a_stalling_host_changes_nothing_in_board_time():
    quick = _timed_move(0.0)
    slow = _timed_move(0.03)  # > 1 s of wall-clock stalls during a 1 s move: 10 s of board time if it ran free
    assert slow[3] >= 30
    assert slow[0] == quick[0]  # the same board time when the move was over, to the millisecond
    assert repr(slow[1]) == repr(quick[1])  # the same STATUS (state, q, counters, board time, last=)
    assert slow[1].state == "IDLE"
    np.testing.assert_allclose(slow[1].q, np.radians([30.0, 60.0, 120.0]), atol=math.radians(0.01))
    assert not any(name == "HOLD" for name, _ in slow[2]), slow[2]


def test_port_waits_in_board_time_and_counts_the_bytes():
    with FirmwareSim() as sim:
        port = sim.open_port(baudrate=115200, timeout=0.2)
        assert isinstance(port, SimavrPort) and port.clock == "lockstep" and sim.stepped
        assert port.readline().startswith(b"READY labkit-arm 3 ")
        t0 = port.board_time
        time.sleep(0.2)  # wall-clock time passes, board time does not
        assert port.board_time == t0 == sim.time()
        assert port.read(1) == b""  # nothing to read: the read timeout passed in simulated time
        assert port.board_time == pytest.approx(t0 + 0.2, abs=1e-5)
        port.write(b"PING\n")
        line = port.readline()
        assert line.startswith(b"OK PING ")
        assert port.board_time - (t0 + 0.2) < 0.01  # one line: a PING and its reply on a 115200-baud wire
        assert sim.board_bytes == port._bytes_read and port.in_waiting == 0
        port.sleep(0.5)
        assert port.board_time == pytest.approx(t0 + 0.7, abs=0.01)
        port.close()


def test_stepped_simulator_refuses_what_it_cannot_do():
    with FirmwareSim() as sim:
        with pytest.raises(DeviceError, match="needs a stepped, running simulator"):
            sim.advance(0.1)
        port = sim.open_port(timeout=0.1)
        with pytest.raises(DeviceError, match="before run"):
            sim.open_port()
        with pytest.raises(OptionError, match="expected seconds >= 0"):
            sim.advance(-1.0)
        with pytest.raises(OptionError, match="expected a timeout >= 0 s or None, got -1"):
            port.timeout = -1
        port.close()
    with pytest.raises(OptionError, match="expected clock one of lockstep, realtime, got 'wall'"):
        SimavrPort(None, clock="wall")


def test_paced_simavr_keeps_the_wall_clock():
    port = serial.serial_for_url("simavr://?pace=1", baudrate=115200, timeout=1.0)
    try:
        assert port.clock == "realtime" and port.time_scale == 1.0 and not port.sim.stepped
        assert port.readline().startswith(b"READY labkit-arm 3 ")
        assert port.board_time > 0  # simulated time, read from the simulator
    finally:
        port.close()
