"""The board's firmware in Python: request lines, commands, segment queue, servo and stream frames.

:class:`Executor` is what every in-process board runs, whatever servos it drives: the virtual
board (:class:`labkit.arm.VirtualBoard`, hobby servos and their simulated physics) and the host-side
board of a servo bus (:class:`labkit.arm.bus.BusBoard`) each *hold* one and hand it themselves as its
``servos``. The executor owns the board's state (commanded joints, calibration, speed limits, the
segment queue, the feedback stream, the host-silence timer, the remembered sealed requests, the
EEPROM image), its clock and its output bytes; its request-line parser and command handlers are
in ``_commands.py``. It never touches a servo: at every 20 ms servo frame, every ``READ`` and every
stream frame it asks its ``servos`` (the :class:`Servos` interface below), so the same checks,
replies and segment execution run on every board.
"""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

from labkit.arm._protocol import MAX_LINE, PROTOCOL_VERSION, seal
from labkit.arm.board._commands import FW_VERSION, BoardCommands, read_eeprom

__all__ = ["Executor", "Servos"]

FRAME_S = 0.020  # servo frame period [s]
BOOT_S = 0.1  # reset to READY [s]


@runtime_checkable
class Servos(Protocol):
    """What an :class:`Executor` asks of the servos its board drives (the board implements it).

    Joint values are centidegrees of the joint (``q``), as on the wire; ``cal`` is a channel's
    calibration row ``[pmin, pmax, zero, direction, lo, hi]`` (``CAL``), which hobby servos use
    and a servo bus ignores (its servos' range is the robot file's joint limits).

    Attributes
    ----------
    grip_refused : str
        Why ``GRIP`` is refused (``ERR 5 RANGE <text>``) when the board drives no gripper servo; ``""``: driven.
    """

    grip_refused: str

    def joint_range(self, j, cal):
        """Joint ``j``'s feasible range (what ``SEG`` checks).

        Parameters
        ----------
        j : int
            Joint index.
        cal : sequence of int
            The channel's calibration row.

        Returns
        -------
        tuple of int
            ``(lo, hi)`` [cdeg].
        """

    def valid(self, j, q, cal):
        """Whether joint ``j`` may be commanded to ``q`` (what ``MOVE`` and ``CAL`` check).

        Parameters
        ----------
        j : int
            Joint index.
        q : float
            Joint value [cdeg].
        cal : sequence of int
            The channel's calibration row.

        Returns
        -------
        bool
        """

    def clamp(self, j, q, cal):
        """``q`` brought into joint ``j``'s range (the executor's last safety net).

        Parameters
        ----------
        j : int
            Joint index.
        q : float
            Joint value [cdeg].
        cal : sequence of int
            The channel's calibration row.

        Returns
        -------
        float
            Joint value [cdeg].
        """

    def power_up(self):
        """Called at every boot once the executor's state is set: start where the servos are (may set ``q``)."""

    def frame(self):
        """A 20 ms servo frame: drive the servos to the executor's ``q`` and ``grip`` at its ``time``."""

    def settle(self):
        """Bring whatever the servos simulate up to the executor's ``time`` (nothing on real servos)."""

    def feedback(self):
        """``READ``'s counts now: one per joint (0..1023), then the user pot, as a list of int."""

    def stream_frame(self, counter, t_ms):
        """A stream frame is due.

        Parameters
        ----------
        counter : int
            Frame counter (0..65535).
        t_ms : int
            Board clock [ms].

        Returns
        -------
        list of int or None
            The counts of its ``FB`` line, or ``None``: no line is sent.
        """

    def stream_rate(self, hz):
        """``STREAM hz`` was accepted.

        Parameters
        ----------
        hz : int
            Frame rate [Hz], 0: off.
        """


class Executor(BoardCommands):
    """The firmware's state machine, clocked explicitly (see the module notes).

    Parameters
    ----------
    servos : Servos
        The servos the board drives (the board itself).
    joints : int
        Joint count (channels: ``joints + 1``, the last the gripper).
    queue : int
        Segment queue depth reported by ``HELLO``.
    eeprom : bytearray, optional
        The board's EEPROM (1 kB; default erased: the factory calibration boots).

    Attributes
    ----------
    time : float
        Board time [s] since power-up.
    q : list of float
        Commanded joint values [cdeg].
    state : str
        ``"IDLE"``, ``"RUN"`` or ``"HOLD"``.
    segments : list
        The segment queue, the running one first.
    done : int
        Segments finished since boot.
    """

    def __init__(self, servos, joints, *, queue=6, eeprom=None):
        self.servos = servos
        self.joints = int(joints)
        self.channels = self.joints + 1
        self.queue_depth = int(queue)
        self.eeprom = bytearray(b"\xff" * 1024) if eeprom is None else eeprom
        self.time = 0.0


    @property
    def grip_refused(self):
        """Why ``GRIP`` is refused on this board (its servos' ``grip_refused``)."""
        return self.servos.grip_refused

    # -- power-up --------------------------------------------------------------
    def boot(self, reason="POWER"):
        """Start (power-up, or a reset): RAM state from the EEPROM, the servos asked where they are, ``READY`` 0.1 s later.

        The board calls it once after creating the executor (its ``servos`` can be reached by then).

        Parameters
        ----------
        reason : str
            Reset cause reported in ``READY ... reset=<reason>``.
        """
        self.boot_time = self.time
        self._out = bytearray()
        self._inbuf = bytearray()
        self._discarding = False
        self.flags = 0
        self.cal, self.vmax, self.amax, self.timeout_ms, ok = read_eeprom(self.eeprom, self.channels)
        if not ok:
            self.flags |= 0x01
        self.q = [self._clamp_servo(j, (self.cal[j][4] + self.cal[j][5]) / 2) for j in range(self.joints)]
        g = self.cal[self.joints]
        self.grip = (g[0] + g[1]) / 2
        self.state = "IDLE"
        self.segments = []
        self.done = 0
        self.stream_hz = 0
        self.stream_next = math.inf
        self.stream_counter = 0
        self.last_ok = self.time
        self.last_seq = 0
        #: ``((seq, echo), fields)`` of the last accepted sealed requests, oldest first (repeats are answered from it)
        self.seen = []
        #: a sealed request was accepted since power-up or ``HELLO``: ``last_seq`` is the newest (older ones are stale)
        self.window = False
        self.next_frame = self.time
        self.mem = 812
        self._boot_pending = (reason, ok)
        self.servos.power_up()

    @property
    def clock_ms(self):
        """Board clock [ms since the last boot] (uint32)."""
        return int((self.time - self.boot_time) * 1000 + 1e-6) % 2**32

    # -- the servos' range (the commands' checks ask it) ---------------------------
    def _valid(self, j, q, cal=None):
        return self.servos.valid(j, q, cal or self.cal[j])

    def _clamp_servo(self, j, q):
        return self.servos.clamp(j, q, self.cal[j])

    def _feasible(self, j):
        return self.servos.joint_range(j, self.cal[j])

    # -- host side of the wire -----------------------------------------------------
    def receive(self, data):
        """Bytes arriving from the host at the current board time.

        Complete lines (ended by LF or CR) are handled at once; a line longer than
        the protocol's limit is discarded with ``ERR 4 TOOLONG``.

        Parameters
        ----------
        data : bytes-like
            Bytes from the host.
        """
        for b in bytes(data):
            if b in (10, 13):
                if self._discarding:
                    self._discarding = False
                    self._emit("ERR 4 TOOLONG")
                elif self._inbuf:
                    line = bytes(self._inbuf)
                    self._inbuf.clear()
                    self._handle(line)
                continue
            if self._discarding:
                continue
            self._inbuf.append(b)
            if len(self._inbuf) > MAX_LINE:
                self._inbuf.clear()
                self._discarding = True
                self.flags |= 0x10

    def take_output(self, size=None):
        """Remove and return up to ``size`` bytes the board has sent (all if ``None``).

        Parameters
        ----------
        size : int, optional
            Largest number of bytes to take; default all pending.

        Returns
        -------
        bytes
            Pending output, oldest first (empty if none).
        """
        if size is None or size >= len(self._out):
            out, self._out = bytes(self._out), bytearray()
            return out
        out = bytes(self._out[:size])
        del self._out[:size]
        return out

    @property
    def out_waiting(self):
        """Number of bytes sent by the board and not yet taken."""
        return len(self._out)

    def _emit(self, text):
        self._out += (seal(text) + "\r\n").encode("ascii")

    # -- clock -----------------------------------------------------------------
    def next_event_time(self):
        """Board time [s] of the next scheduled activity (boot, servo frame or stream frame).

        Returns
        -------
        float
            Board time [s].
        """
        if self._boot_pending:
            return self.boot_time + BOOT_S
        return min(self.next_frame, self.stream_next)

    def advance_to(self, t):
        """Run the board until board time ``t`` [s], emitting what falls due.

        Parameters
        ----------
        t : float
            Board time to reach [s] (no-op for the past).
        """
        while True:
            if self._boot_pending and self.boot_time + BOOT_S <= t:
                self.time = max(self.time, self.boot_time + BOOT_S)
                reason, ok = self._boot_pending
                self._boot_pending = None
                self._emit(f"READY labkit-arm {PROTOCOL_VERSION} fw={FW_VERSION} proto={PROTOCOL_VERSION} "
                           f"joints={self.joints} "
                           f"reset={reason} eeprom={'OK' if ok else 'DEFAULTS'}")
                continue
            nxt = min(self.next_frame, self.stream_next)
            if nxt > t:
                break
            self.time = nxt
            if self.next_frame <= self.stream_next:
                self._servo_frame()
                self.next_frame = round(self.next_frame + FRAME_S, 9)
            else:
                self._stream_frame()
        self.time = max(self.time, t)
        self.servos.settle()

    def advance(self, dt):
        """Run the board for ``dt`` seconds of board time.

        Parameters
        ----------
        dt : float
            Board time to run [s].
        """
        self.advance_to(self.time + dt)

    def _servo_frame(self):
        t = self.time
        if self.state == "RUN" and self.timeout_ms and (t - self.last_ok) * 1000 > self.timeout_ms:
            self._halt()
            self.state = "HOLD"
            self.flags |= 0x02
            self._emit("EV HOLD " + " ".join(str(v) for v in self._q_int()))
        if self.state == "RUN":
            while self.segments and t >= self.segments[0].start + self.segments[0].dur - 1e-9:
                seg = self.segments.pop(0)
                self.done += 1
                self.q = [float(v) for v in seg.at(1.0)]
                if self.segments:
                    self.segments[0].start = seg.start + seg.dur
            if self.segments:
                seg = self.segments[0]
                self.q = [float(v) for v in seg.at((t - seg.start) / seg.dur)]
            else:
                self.state = "IDLE"
                self._emit(f"EV DONE {self.done}")
            for j in range(self.joints):
                c = self._clamp_servo(j, self.q[j])
                if c != self.q[j]:
                    self.flags |= 0x04
                    self.q[j] = c
        self.servos.frame()

    def _stream_frame(self):
        t_ms = self.clock_ms
        counts = self.servos.stream_frame(self.stream_counter, t_ms)
        if counts is not None:
            self._emit(f"FB {self.stream_counter} {t_ms} " + " ".join(str(a) for a in counts))
        self.stream_counter = (self.stream_counter + 1) % 65536
        self._stream_k += 1
        self.stream_next = self._stream_t0 + self._stream_k / self.stream_hz

    def _adc(self):
        return self.servos.feedback()

    def _q_int(self):
        return [int(round(v)) for v in self.q]

    def _halt(self):
        self.segments.clear()
        self.state = "IDLE"
