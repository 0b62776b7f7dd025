"""A pyserial port on the firmware simulator's pty whose waits run in board time.

:class:`SimavrPort` is what ``simavr://`` URLs and :meth:`labkit.arm.FirmwareSim.open_port`
return. Its ``clock`` says how the simulator's time relates to the host's waits:

``"lockstep"``
    The simulator is stepped (:meth:`labkit.arm.FirmwareSim.set_stepped`): simulated time
    advances only while the host waits in :meth:`SimavrPort.read` (by at most the read timeout,
    in seconds of *board* time, and only until the board completes a line or the requested
    bytes are in) or in :meth:`SimavrPort.sleep`. The host's clock (:attr:`SimavrPort.board_time`)
    is the simulated one, so a reply timeout costs 50 ms of simulated time (a few ms of wall
    time), and a loaded machine cannot make the board see a silent host: what happens is a
    function of the bytes and of the waits only (like ``sim://?clock=lockstep``).
``"realtime"``
    The simulator runs free (about 10x real time) or paced to the wall clock (``pace=1``); reads
    wait on the wall clock, :attr:`SimavrPort.board_time` still reads simulated time.

The port is a :class:`labkit.arm.BoardPort`: the link (:class:`labkit.arm.Arm`) reads its
``board_time``, ``clock`` and ``time_scale`` and keeps every wait and timeout in board seconds.
"""

from __future__ import annotations

import time

from serial import serialposix
from serial.serialutil import to_bytes

from labkit.exceptions import PortError
from labkit.exceptions import OptionError

__all__ = ["CLOCKS", "SimavrPort"]

CLOCKS = ("lockstep", "realtime")
"""Valid ``clock`` values of :class:`SimavrPort`."""

FREE_RUN_SCALE = 10.0
"""Nominal simulated seconds per wall-clock second of a free-running simulator (``pace=0``)."""

_RESOLUTION_S = 1e-6  # simulated time is reported in whole microseconds (a cycle is 62.5 ns)
_TRANSIT_S = 10.0  # wall-clock limit for board bytes known to be on their way through the pty
_WRITE_CHUNK = 1024  # largest lockstep write before the UART is given the time to take it [bytes]
_BYTE_S = 10 / 115200  # wire time of one byte at 115200 baud, 8N1 [s]


class SimavrPort(serialposix.Serial):
    """A pyserial port on a :class:`labkit.arm.FirmwareSim`'s pty (see the module docstring).

    Parameters
    ----------
    sim : FirmwareSim
        A started simulator whose CPU is still held (pyserial flushes input on open).
    clock : {"lockstep", "realtime"}
        How waits relate to simulated time; ``"lockstep"`` switches the simulator to stepping.
    **serial_options
        ``baudrate``, ``timeout`` [s; of board time when lockstep] ... of :class:`serial.Serial`.

    Raises
    ------
    OptionError
        An unknown ``clock`` (a ``ValueError``).
    serial.SerialException
        The pty cannot be opened.

    Examples
    --------
    >>> from labkit.arm import FirmwareSim
    >>> with FirmwareSim() as sim:                               # doctest: +SKIP
    ...     port = sim.open_port(timeout=0.5)                   # lockstep, CPU running
    ...     port.readline()[:19], round(port.board_time, 3)      # 0.5 s of board time at most
    (b'READY labkit-arm 3 ', 0.002)
    """

    sim = None
    #: the arm model the firmware's servo pulses drive (``simavr://?physics=``), else None
    physics = None

    def __init__(self, sim=None, *, clock="lockstep", **serial_options):
        if clock not in CLOCKS:
            raise OptionError(f"expected clock one of {', '.join(CLOCKS)}, got {clock!r}")
        self._clock = clock
        self._bytes_read = 0
        port = serial_options.pop("port", None)
        if sim is not None:
            self.sim = sim
            port = sim.port
        super().__init__(port, **serial_options)

    # -- clock ------------------------------------------------------------------------------
    @property
    def clock(self):
        """``"lockstep"`` (simulated time advances only while the host waits) or ``"realtime"``."""
        return self._clock

    @property
    def time_scale(self):
        """Simulated seconds per wall-clock second when ``clock == "realtime"`` (nominal when free running)."""
        return self.sim.pace if self.sim.pace > 0 else FREE_RUN_SCALE

    @property
    def board_time(self):
        """Simulated time since power-on [s]: the link's clock for this port.

        Returns
        -------
        float
            Simulated seconds (lockstep: where the last wait left it, no round trip).
        """
        if self._clock == "lockstep":
            return self.sim.board_time
        return self.sim.time()

    @property
    def virtual_model(self):
        """The simulated arm behind the firmware (:class:`labkit.arm.ArmModel`) with ``physics``, else ``None``."""
        return None if self.physics is None else self.physics.model

    def read_servos(self):
        """``None``: the firmware drives hobby servos, whose joints come back only as ``READ`` and ``FB`` lines.

        Returns
        -------
        None
        """
        return None

    def servo_bus(self):
        """``None``: the board drives hobby servos, which have no bus to reach.

        Returns
        -------
        None
        """
        return None

    def servo_stream(self):
        """``None``: the firmware's stream frames travel as ``FB`` lines.

        Returns
        -------
        None
        """
        return None

    def sleep(self, seconds):
        """Let ``seconds`` of board time pass (lockstep: the simulator runs them at full speed).

        Parameters
        ----------
        seconds : float
            Board time [s].
        """
        if self._clock == "lockstep":
            self.sim.advance(seconds)
        else:
            time.sleep(seconds / self.time_scale)

    # -- pyserial plumbing -------------------------------------------------------------------
    def open(self):
        """Open the pty; with the lockstep clock, switch the simulator to stepping first."""
        if self._clock == "lockstep" and self.sim is not None and not self.sim.stepped:
            self.sim.set_stepped(True)
        super().open()

    @property
    def timeout(self):
        """Read timeout [s] (of board time when lockstep), or ``None`` to wait for ``size`` bytes."""
        return self._timeout

    @timeout.setter
    def timeout(self, value):
        # only stored: the pty's termios settings do not depend on it (pyserial waits with select),
        # and the link sets it before every read
        if value is not None and not value >= 0:
            raise OptionError(f"expected a timeout >= 0 s or None, got {value!r}")
        self._timeout = value

    def _lockstep(self):
        return self._clock == "lockstep" and self.is_open

    @property
    def in_waiting(self):
        """Bytes ready to read (lockstep: the board's bytes written to the pty and not read yet)."""
        if not self._lockstep():
            return super().in_waiting
        return max(self.sim.board_bytes - self._bytes_read, 0)

    def _take(self, size):
        """Read ``size`` bytes the simulator reported as written (they may still cross the pty)."""
        timeout, self._timeout = self._timeout, _TRANSIT_S
        try:
            data = super().read(size)
        finally:
            self._timeout = timeout
        if len(data) < size:
            raise PortError(f"{self.portstr}: {size - len(data)} of the simulator's bytes did not "
                                  f"arrive through the pty within {_TRANSIT_S:g} s")
        self._bytes_read += len(data)
        return data

    def read(self, size=1):
        """Read up to ``size`` bytes, waiting up to ``timeout`` (lockstep: of board time).

        Lockstep, the wait is simulated: the CPU runs until the board completes a line or the
        timeout's simulated seconds have passed, as often as needed for ``size`` bytes.

        Parameters
        ----------
        size : int
            Largest number of bytes.

        Returns
        -------
        bytes
            Fewer than ``size`` bytes only if the timeout passed.

        Raises
        ------
        serial.SerialException
            Lockstep without a timeout and nothing to read (it would wait forever), the port
            is closed, or the simulator failed.
        """
        if not self._lockstep():
            return super().read(size)
        data = bytearray()
        timeout = self._timeout
        limit = None if timeout is None else self.sim.board_time + timeout
        while len(data) < size:
            pending = self.sim.board_bytes - self._bytes_read
            if pending > 0:
                data += self._take(min(pending, size - len(data)))
                continue
            if limit is None:
                self._advance(1.0)  # a blocking read: whatever the board sends next
                continue
            left = limit - self.sim.board_time
            if left <= 0:
                break
            self._advance(max(left, _RESOLUTION_S))  # a step the board's clock can show
        return bytes(data)

    def _advance(self, seconds):
        try:
            self.sim.advance(seconds, until_line=True)
        except Exception as exc:  # DeviceError of a failed simulator: a failing port to pyserial users
            raise PortError(f"{self.portstr}: {exc}") from exc

    def write(self, data):
        """Write ``data`` to the pty (lockstep: counted, so the next wait first delivers it).

        Parameters
        ----------
        data : bytes-like

        Returns
        -------
        int
            Bytes written.
        """
        if not (self._clock == "lockstep" and self.sim is not None):
            return super().write(data)
        # lockstep: the CPU runs only while the host waits, so the pty and the harness's buffer (8 kB) would fill
        # and a large write block forever; a chunk at a time, each followed by its wire time of board time (the
        # UART takes the bytes at the baud rate, as a real port would)
        data = memoryview(to_bytes(data))
        n = 0
        while n < len(data):
            chunk = data[n:n + _WRITE_CHUNK]
            k = super().write(chunk)
            n += k
            self.sim.host_bytes += k
            if len(data) > _WRITE_CHUNK:
                self._advance_wire(k * _BYTE_S)
        return n

    def _advance_wire(self, seconds):
        try:
            self.sim.advance(seconds)
        except Exception as exc:  # DeviceError of a failed simulator: a failing port to pyserial users
            raise PortError(f"{self.portstr}: {exc}") from exc

    def reset_input_buffer(self):
        """Discard the bytes received and not read (lockstep: read and dropped, so the count stays exact)."""
        if not self._lockstep():
            super().reset_input_buffer()
            return
        pending = self.sim.board_bytes - self._bytes_read
        if pending > 0:
            self._take(pending)
