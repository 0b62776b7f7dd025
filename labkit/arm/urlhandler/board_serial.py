"""A pyserial port whose other end is a board object in this process (``sim://``, the servo buses).

:class:`BoardSerial` is the :class:`labkit.arm.BoardPort` of every in-process board: the virtual
board (:class:`labkit.arm.VirtualBoard`, ``sim://``) and the host-side board of a servo bus
(:class:`labkit.arm.bus.BusBoard`, ``sim://...?bus=``, ``dynamixel://``, ``feetech://``). The URL
handlers subclass it only to create their board in ``open``; everything the host does with the port
(bytes both ways, the clock, the servos' readings, the simulated arm) is here and asks the board.

A board object has ``receive(bytes)``, ``take_output(size)``, ``out_waiting``, ``advance_to(t)``,
``next_event_time()``, ``time`` [s], ``read_servos()``, ``servo_stream()``, ``virtual_model`` and
``shutdown()``.

The ``clock`` is ``realtime`` (board time = ``time_scale`` x the wall clock since open) or
``lockstep`` (board time advances only while the host waits in ``read``, by the read timeout, or
in :meth:`BoardSerial.sleep`; deterministic and as fast as the host can go, for tests).
"""

from __future__ import annotations

import math
import time

from serial.serialutil import SerialBase, to_bytes

from labkit.exceptions import PortClosedError, PortError

__all__ = ["BoardSerial"]

#: longest wait [s of board time] of a lockstep read with ``timeout=None`` before it fails
_BLOCKING_LIMIT = 120.0


class BoardSerial(SerialBase):
    """A pyserial port on an in-process board (attribute ``board``; see the module notes).

    Subclasses create the board in ``open`` and set ``board``, ``_clock``, ``_scale``, ``_t0`` and
    ``is_open``.
    """

    def __init__(self, *args, **kwargs):
        self.board = None
        self._clock = "realtime"
        self._scale = 1.0
        self._t0 = 0.0
        super().__init__(*args, **kwargs)

    def close(self):
        """Close the port; the board object stays inspectable (a bus board turns torque off, its bus closes)."""
        if self.is_open and self.board is not None:
            self.board.shutdown()
        self.is_open = False  # the board object stays inspectable after close
        super().close()

    # -- what a board offers beside its lines ----------------------------------------------------
    @property
    def virtual_model(self):
        """The simulated arm (:class:`labkit.arm.ArmModel`), ``None`` behind a real servo bus."""
        return None if self.board is None else self.board.virtual_model

    def read_servos(self):
        """A sync read of every servo of a bus board now, ``None`` on a hobby-servo board.

        Returns
        -------
        BusReading or None

        Raises
        ------
        BusFault
            The bus failed.
        """
        self._check_open()
        self._sync()
        return self.board.read_servos()

    def servo_bus(self):
        """The servo bus behind the port (a :class:`labkit.arm.bus.BusBoard`), ``None`` on a hobby-servo board.

        Returns
        -------
        BusBoard or None
        """
        self._check_open()
        self._sync()
        return self.board.servo_bus()

    def servo_stream(self):
        """The stream frames a bus board read since ``STREAM`` was switched on, ``None`` on a hobby-servo board.

        Returns
        -------
        list of tuple or None
        """
        self._check_open()
        return self.board.servo_stream()

    def _reconfigure_port(self):
        pass

    def _update_dtr_state(self):
        pass

    def _update_rts_state(self):
        pass

    def _update_break_state(self):
        pass

    @property
    def cts(self):
        return True

    @property
    def dsr(self):
        return True

    @property
    def ri(self):
        return False

    @property
    def cd(self):
        return True

    # -- clock -------------------------------------------------------------------------
    @property
    def clock(self):
        """``"realtime"`` or ``"lockstep"``."""
        return self._clock

    @property
    def time_scale(self):
        """Board seconds per wall-clock second (realtime clock)."""
        return self._scale

    @property
    def board_time(self):
        """Board time since power-up [s]: the link's clock for this port (brought up to date first).

        Returns
        -------
        float
        """
        if self.is_open:
            self._sync()
        return self.board.time

    def _sync(self):
        if self._clock == "realtime":
            self.board.advance_to((time.monotonic() - self._t0) * self._scale)

    def sleep(self, seconds):
        """Let ``seconds`` of *board* time pass (lockstep: instantly).

        Parameters
        ----------
        seconds : float
            Board time [s].
        """
        self._check_open()
        if self._clock == "lockstep":
            self.board.advance(seconds)
        else:
            time.sleep(seconds / self._scale)
            self._sync()

    def _check_open(self):
        if not self.is_open or self.board is None:
            raise PortClosedError(self.port)

    # -- data ----------------------------------------------------------------------------
    @property
    def in_waiting(self):
        self._check_open()
        self._sync()
        return self.board.out_waiting

    def read(self, size=1):
        """Read up to ``size`` bytes the board sent, waiting up to ``timeout`` (board time when lockstep).

        Parameters
        ----------
        size : int
            Largest number of bytes.

        Returns
        -------
        bytes
        """
        self._check_open()
        board = self.board
        timeout = self._timeout
        data = bytearray()
        if self._clock == "lockstep":
            # timeout=None blocks until `size` bytes came; in lockstep a board that sends nothing would make that
            # an endless loop of servo frames, so the wait ends with an error after _BLOCKING_LIMIT of board time
            limit = board.time + (_BLOCKING_LIMIT if timeout is None else timeout)
            while len(data) < size:
                if board.out_waiting:
                    data += board.take_output(size - len(data))
                    continue
                nxt = min(board.next_event_time(), limit)
                if board.time >= limit or math.isinf(nxt):
                    if timeout is not None:
                        break
                    raise PortError(f"{self.port}: expected a read timeout with clock=lockstep (board time passes "
                                    f"only while the host waits), got timeout=None and {len(data)} of {size} "
                                    f"bytes after {_BLOCKING_LIMIT:g} s of board time: the read would block forever")
                board.advance_to(nxt)
            return bytes(data)
        deadline = None if timeout is None else time.monotonic() + timeout
        while len(data) < size:
            self._sync()
            if board.out_waiting:
                data += board.take_output(size - len(data))
                continue
            now = time.monotonic()
            if deadline is not None and now >= deadline:
                break
            time.sleep(0.0005 if deadline is None else min(0.0005, deadline - now))
        return bytes(data)

    def write(self, data):
        """Send ``data`` to the board at the current board time.

        Parameters
        ----------
        data : bytes-like

        Returns
        -------
        int
            ``len(data)``.
        """
        self._check_open()
        data = to_bytes(data)
        self._sync()
        self.board.receive(data)
        return len(data)

    def reset_input_buffer(self):
        """Discard what the board has sent and the host has not read."""
        self._check_open()
        self._sync()
        self.board.take_output()

    def reset_output_buffer(self):
        """Nothing to discard: written bytes reach the board at once."""
        self._check_open()

    @property
    def out_waiting(self):
        return 0
