"""The virtual arm: a pure-Python board speaking ``docs/protocol.md`` (version 2).

:class:`VirtualBoard` is the board's state machine (segment queue, servo
frames, feedback stream, host-silence timeout, virtual EEPROM) driving the
servo physics of :class:`labkit.arm.ArmModel`; its request-line parser and
command handlers are in ``_commands.py`` and the wire format (checksum, error
codes, line limit) in ``_protocol.py``, shared with the host. It is byte-level
and clocked explicitly: :meth:`VirtualBoard.receive` feeds bytes from the
host, :meth:`VirtualBoard.advance_to` moves board time forward (emitting
servo frames, ``FB`` frames and events at their exact times), and
:meth:`VirtualBoard.take_output` returns the bytes the board sent.

Reach it as ``serial.serial_for_url("sim://...")`` (see
:mod:`labkit.arm.urlhandler.protocol_sim`) or serve it on a pseudo-terminal with
``labkit sim`` for any serial tool.

Examples
--------
>>> board = VirtualBoard("arduino_arm_3dof")
>>> board.advance_to(0.2)
>>> board.take_output().split(b" ")[:3]
[b'READY', b'labkit-arm', b'3']
>>> board.receive(b"#7 PING\\n")
>>> board.take_output()
b'OK #7 PING 200*B63589B2\\r\\n'
"""

from __future__ import annotations

import math

import numpy as np

from labkit.robot import Robot
from labkit.arm._protocol import MAX_LINE, PROTOCOL_VERSION, seal, wire_calibrations, wire_speed_limits
from labkit.arm.board._physics import PhysicsConfig
from labkit.arm.board._model import ArmModel
from labkit.arm.board._commands import FACTORY, FW_VERSION, BoardCommands, eeprom_image, read_eeprom

__all__ = ["VirtualBoard"]

FRAME_S = 0.020  # servo frame period [s]
BOOT_S = 0.1  # reset to READY [s]


def calibration_rows(robot):
    """The board calibration ``[pmin, pmax, zero, direction, lo, hi]`` of every channel of ``robot``.

    The rows :meth:`labkit.arm.Arm.sync_calibration` sends with ``CAL``: the pulse widths at
    servo angles 0 and 180 deg [us], the servo angle at ``q = 0`` and the joint limits [cdeg]
    (prismatic joints in metres read as radians, as on the wire). Joints without a servo and the
    gripper channel keep the factory row (the gripper: its pulse range).

    Parameters
    ----------
    robot : Robot or str
        The robot (file).

    Returns
    -------
    list of list of int
        ``robot.n + 1`` rows (joints, then the gripper channel).
    """
    robot = Robot.load(robot)
    joints, gripper = wire_calibrations(robot)
    rows = [list(FACTORY) if row is None else row for row in joints] + [list(FACTORY) if gripper is None else gripper]
    return rows


class VirtualBoard(BoardCommands):
    """Protocol-v2 board with simulated servo physics.

    Parameters
    ----------
    robot : Robot or str
        The arm (its servo calibrations are the *true* servos of the physics).
    config : PhysicsConfig
        Physics parameters and seed.
    queue : int
        Segment queue depth reported by ``HELLO``.
    user_pot : int
        ADC counts of the user potentiometer on A5 (settable attribute).

    Attributes
    ----------
    time : float
        Board time [s] since power-up.
    model : ArmModel
        The physics (offsets, sag, ruler: ``board.model.ruler(3)``).
    sent_frames : dict
        ``{counter: (t_ms, adc tuple)}`` of the last ``FB`` frames emitted
        (ground truth for fault tests; keeps the last 100,000).
    """

    def __init__(self, robot="arduino_arm_3dof", config=PhysicsConfig(), *, queue=6, user_pot=512,
                 saved_calibration=False):
        self.robot = Robot.load(robot)
        self.joints = self.robot.n
        self.channels = self.joints + 1
        self.queue_depth = int(queue)
        self.user_pot = int(user_pot)
        self.config = config
        self.eeprom = bytearray(b"\xff" * 1024)
        if saved_calibration:  # a board whose EEPROM already holds the robot file's calibration (CAL + SAVE)
            img = eeprom_image(calibration_rows(self.robot), *wire_speed_limits(self.robot), 500)
            self.eeprom[: len(img)] = img
        self.sent_frames = {}
        #: analog pins forced to a voltage (``set_analog``), overriding the physics
        self.analog_override = {}
        #: servo pulse widths now ``{channel: us}`` and their changes ``[(t, channel, us)]``
        self.pulses = {}
        self.pulse_log = []
        self.time = 0.0
        self.model = None
        self._boot("POWER", config)

    # -- power-up --------------------------------------------------------------
    def _boot(self, reason, config):
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
        if self.model is None:  # power-up: the arm rests at the boot position; a reset keeps it where it is
            self.model = ArmModel(self.robot, config, q0=np.radians(np.array(self.q) / 100.0))
        self._boot_pending = (reason, ok)

    def reset(self, reason="EXTERNAL"):
        """Reset the MCU (as DTR on open does): RAM state lost, EEPROM kept, ``READY`` 0.1 s later.

        Parameters
        ----------
        reason : str
            Reset cause reported in ``READY ... reset=<reason>``.
        """
        self._boot(reason, self.config)

    @property
    def clock_ms(self):
        """Board clock [ms since the last boot] (uint32)."""
        return int((self.time - self.boot_time) * 1000 + 1e-6) % 2**32

    def set_analog(self, pin, volts):
        """Force analog pin ``pin`` (0..5) to ``volts`` (``None`` returns it to the physics).

        Parameters
        ----------
        pin : int
            Analog input number, 0..5.
        volts : float or None
            Voltage the pin reads [V]; ``None`` removes the override.
        """
        if volts is None:
            self.analog_override.pop(int(pin), None)
        else:
            self.analog_override[int(pin)] = float(volts)

    # -- servo maths (centidegrees) ----------------------------------------------
    def _servo_cdeg(self, j, q):
        c = self.cal[j]
        return c[2] + c[3] * q

    def _clamp_servo(self, j, q):
        c = self.cal[j]
        lo, hi = c[4], c[5]
        q = min(max(q, lo), hi)
        s = self._servo_cdeg(j, q)
        if s < 0 or s > 18000:
            q = (min(max(s, 0), 18000) - c[2]) * c[3]
        return q

    def _valid(self, j, q, cal=None):
        c = cal or self.cal[j]
        s = c[2] + c[3] * q
        return c[4] <= q <= c[5] and 0 <= s <= 18000

    def _pulse(self, ch, q_cdeg=None, servo_cdeg=None):
        c = self.cal[ch]
        s = servo_cdeg if servo_cdeg is not None else self._servo_cdeg(ch, q_cdeg)
        return round((c[0] + s * (c[1] - c[0]) / 18000.0) * 2) / 2

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
        """Board time [s] of the next scheduled activity (boot, servo frame or FB frame).

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
        self.model.advance_to(self.time)

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
        self.model.advance_to(t)
        pulses = {j: self._pulse(j, self.q[j]) for j in range(self.joints)}
        pulses[self.joints] = float(self.grip)
        for ch, us in pulses.items():
            if self.pulses.get(ch) != us:
                self.pulse_log.append((t, ch, us))
        if len(self.pulse_log) > 200_000:
            del self.pulse_log[:100_000]
        self.pulses = pulses
        self.model.command_pulses(pulses)

    def _stream_frame(self):
        adc = self._adc()
        t_ms = self.clock_ms
        self._emit(f"FB {self.stream_counter} {t_ms} " + " ".join(str(a) for a in adc))
        self.sent_frames[self.stream_counter] = (t_ms, tuple(adc))
        if len(self.sent_frames) > 100_000:
            self.sent_frames.pop(next(iter(self.sent_frames)))
        self.stream_counter = (self.stream_counter + 1) % 65536
        self._stream_k += 1
        self.stream_next = self._stream_t0 + self._stream_k / self.stream_hz

    def _adc(self):
        self.model.advance_to(self.time)
        counts = [int(a) for a in self.model.feedback_adc()] + [self.user_pot]
        for k, pin in enumerate([*range(self.joints), 5]):
            if pin in self.analog_override:
                counts[k] = min(max(int(math.floor(self.analog_override[pin] * 1024 / 5.0)), 0), 1023)
        return counts

    def _q_int(self):
        return [int(round(v)) for v in self.q]

    def _halt(self):
        self.segments.clear()
        self.state = "IDLE"
