"""The virtual arm: a pure-Python board speaking ``docs/protocol.md`` (version 1).

:class:`VirtualBoard` is the board's state machine (line parser, commands,
segment queue, servo frames, feedback stream, host-silence timeout, virtual
EEPROM) driving the servo physics of :mod:`labkit.physics`. It is byte-level
and clocked explicitly: :meth:`VirtualBoard.receive` feeds bytes from the
host, :meth:`VirtualBoard.advance_to` moves board time forward (emitting
servo frames, ``FB`` frames and events at their exact times), and
:meth:`VirtualBoard.take_output` returns the bytes the board sent.

Reach it as ``serial.serial_for_url("sim://...")`` (see
:mod:`labkit.urlhandler.protocol_sim`) or serve it on a pseudo-terminal with
``labkit sim`` for any serial tool.

Examples
--------
>>> board = VirtualBoard("arduino_arm_3dof")
>>> board.advance_to(0.2)
>>> board.take_output().split(b" ")[:2]
[b'EV', b'BOOT']
>>> board.receive(b"#7 PING*24\\n")
>>> board.take_output()
b'OK #7 PING 200*12\\r\\n'
"""

from __future__ import annotations

import math
import re
import struct
from dataclasses import replace

import numpy as np

from labkit.dh import Robot
from labkit.physics import ArmModel, PhysicsConfig

__all__ = ["VirtualBoard", "checksum", "FW_VERSION", "PROTOCOL_VERSION", "add_cli", "serve_pty"]

FW_VERSION = "1.0.0"
PROTOCOL_VERSION = 1
MAX_LINE = 160
FRAME_S = 0.020
BOOT_S = 0.1
ERRORS = {1: "BADCHK", 2: "SYNTAX", 3: "UNKNOWN", 4: "TOOLONG", 5: "RANGE", 6: "LIMIT", 7: "QFULL",
          8: "BUSY", 9: "DISCONT", 10: "EEPROM"}
_INT = re.compile(r"^[+-]?[0-9]{1,10}$")
_SEQ = re.compile(r"^#([0-9]{1,5})$")
_HEX2 = re.compile(r"^[0-9A-Fa-f]{2}[ \t]*$")
FACTORY = (500, 2500, 0, 1, 0, 18000)


def checksum(text):
    """XOR of the bytes of ``text`` (str or bytes), the protocol's line checksum (int 0..255).

    Parameters
    ----------
    text : str or bytes-like
        Line body (ASCII), without the ``*HH`` suffix.

    Returns
    -------
    int
        Checksum, 0..255 (sent as two hex digits).

    Raises
    ------
    UnicodeEncodeError
        ``text`` is a str with non-ASCII characters.

    Examples
    --------
    >>> f"{checksum('#7 PING'):02X}"
    '24'
    """
    data = text.encode("ascii") if isinstance(text, str) else bytes(text)
    x = 0
    for b in data:
        x ^= b
    return x


class _Reject(Exception):
    def __init__(self, code, text=""):
        self.code = code
        self.text = text


class _Segment:
    __slots__ = ("dur", "coef", "start")

    def __init__(self, dur, coef):
        self.dur = dur  # [s]
        self.coef = coef  # (J, order + 1) [cdeg], normalised time
        self.start = None

    def at(self, s):
        s = min(max(s, 0.0), 1.0)
        return np.polynomial.polynomial.polyval(s, self.coef.T)


class VirtualBoard:
    """Protocol-v1 board with simulated servo physics.

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

    def __init__(self, robot="arduino_arm_3dof", config=PhysicsConfig(), *, queue=6, user_pot=512):
        self.robot = Robot.load(robot)
        self.joints = self.robot.n
        self.channels = self.joints + 1
        self.queue_depth = int(queue)
        self.user_pot = int(user_pot)
        self.config = config
        self.eeprom = bytearray(b"\xff" * 1024)
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
        self.cal, self.timeout_ms, ok = self._load_eeprom()
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
        self.next_frame = self.time
        self.mem = 812
        if self.model is None:  # power-up: the arm rests at the boot position; a reset keeps it where it is
            self.model = ArmModel(self.robot, config, q0=np.radians(np.array(self.q) / 100.0))
        self._boot_pending = (reason, ok)

    def reset(self, reason="EXTERNAL"):
        """Reset the MCU (as DTR on open does): RAM state lost, EEPROM kept, ``EV BOOT`` 0.1 s later.

        Parameters
        ----------
        reason : str
            Reset cause reported in ``EV BOOT ... reset=<reason>``.
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

    def _load_eeprom(self):
        cal = [list(FACTORY) for _ in range(self.channels)]
        e = self.eeprom
        size = 4 + 11 * self.channels + 2
        if e[0:2] != b"LK" or e[2] != 1 or e[3] != self.channels or _crc16(e[:size]) != struct.unpack_from(
                "<H", e, size)[0]:
            return cal, 500, False
        off = 4
        for c in range(self.channels):
            pmin, pmax, zero, d, lo, hi = struct.unpack_from("<hhhbhh", e, off)
            cal[c] = [pmin, pmax, zero, d, lo, hi]
            off += 11
        return cal, struct.unpack_from("<H", e, off)[0], True

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
                    self._emit("ERR 4 TOOLONG line longer than 160 bytes")
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
        self._out += f"{text}*{checksum(text):02X}\r\n".encode("ascii")

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
                self._emit(f"EV BOOT labkit-arm fw={FW_VERSION} proto={PROTOCOL_VERSION} reset={reason} "
                           f"eeprom={'OK' if ok else 'DEFAULTS'}")
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

    # -- request lines -------------------------------------------------------------
    def _handle(self, raw):
        if any(not (0x20 <= b <= 0x7E or b == 9) for b in raw):
            self._emit("ERR 2 SYNTAX bad character in line")
            return
        line = raw.decode("ascii").strip(" \t")
        if not line:
            return
        body = line[1:] if line.startswith("$") else line
        if "*" in body:
            k = body.rindex("*")
            tail = body[k + 1:]
            if not _HEX2.match(tail) or int(tail[:2], 16) != checksum(body[:k]):
                self._emit("ERR 1 BADCHK")
                return
            body = body[:k]
        tokens = body.split()
        if not tokens:
            return
        seq = None
        if tokens[0].startswith("#"):
            m = _SEQ.match(tokens[0])
            if not m or int(m.group(1)) > 65535:
                self._emit("ERR 2 SYNTAX bad sequence id")
                return
            seq = int(m.group(1))
            tokens = tokens[1:]
        tag = f" #{seq}" if seq is not None else ""
        if not tokens:
            self._emit(f"ERR{tag} 2 SYNTAX missing command")
            return
        name = tokens[0].upper()
        handler = getattr(self, f"_cmd_{name.lower()}", None) if name.isalpha() else None
        if handler is None:
            shown = "".join(ch if ch.isalnum() else "?" for ch in tokens[0][:12])
            self._emit(f"ERR{tag} 3 UNKNOWN {shown}")
            return
        try:
            args = []
            for tok in tokens[1:]:
                if not _INT.match(tok) or not -2**31 <= int(tok) < 2**31:
                    raise _Reject(2, f"malformed number {tok[:12]}")
                args.append(int(tok))
            fields = handler(args)
        except _Reject as rej:
            self._emit(f"ERR{tag} {rej.code} {ERRORS[rej.code]} {rej.text}".rstrip())
            return
        self.last_ok = self.time
        self._emit(f"OK{tag} {name}" + (f" {fields}" if fields else ""))

    @staticmethod
    def _nargs(args, *counts):
        if len(args) not in counts:
            raise _Reject(2, f"expected {' or '.join(map(str, counts))} arguments, got {len(args)}")

    def _cmd_hello(self, args):
        self._nargs(args, 0)
        return (f"labkit-arm fw={FW_VERSION} proto={PROTOCOL_VERSION} joints={self.joints} "
                f"channels={self.channels} queue={self.queue_depth} maxline={MAX_LINE}")

    def _cmd_ping(self, args):
        self._nargs(args, 0)
        return str(self.clock_ms)

    def _cmd_status(self, args):
        self._nargs(args, 0)
        used = len(self.segments)
        return (f"state={self.state} q={','.join(str(v) for v in self._q_int())} grip={int(self.grip)} "
                f"queue={used} free={self.queue_depth - used} done={self.done} timeout={self.timeout_ms} "
                f"stream={self.stream_hz} flags={self.flags:02X} mem={self.mem} t={self.clock_ms}")

    def _check_joints(self, q):
        for j, v in enumerate(q):
            if not self._valid(j, v):
                c = self.cal[j]
                raise _Reject(6, f"joint {j} {v} outside {c[4]}..{c[5]}")

    def _cmd_move(self, args):
        self._nargs(args, self.joints)
        self._check_joints(args)
        if self.state == "RUN":
            raise _Reject(8, "trajectory running; send STOP first")
        self.q = [float(v) for v in args]
        self.state = "IDLE"
        return ""

    def _cmd_grip(self, args):
        self._nargs(args, 1)
        c = self.cal[self.joints]
        if not min(c[0], c[1]) <= args[0] <= max(c[0], c[1]):
            raise _Reject(5, f"pulse {args[0]} outside {min(c[0], c[1])}..{max(c[0], c[1])}")
        self.grip = args[0]
        return str(args[0])

    def _cmd_seg(self, args):
        if len(args) < 2:
            raise _Reject(2, "expected dur_ms order coefficients")
        dur, order = args[0], args[1]
        if not 1 <= dur <= 60000 or order not in (3, 5):
            raise _Reject(5, "dur_ms must be 1..60000 and order 3 or 5")
        need = self.joints * (order + 1)
        if len(args) - 2 != need:
            raise _Reject(2, f"expected {need} coefficients, got {len(args) - 2}")
        if len(self.segments) >= self.queue_depth:
            raise _Reject(7, "queue full")
        if any(abs(c) > 10_000_000 for c in args[2:]):
            raise _Reject(5, "coefficient outside +-10000000")
        coef = np.array(args[2:], dtype=float).reshape(self.joints, order + 1)
        seg = _Segment(dur / 1000.0, coef)
        samples = np.round(np.polynomial.polynomial.polyval(np.arange(33) / 32.0, coef.T))  # (J, 33)
        for j in range(self.joints):
            for v in samples[j]:
                if not self._valid(j, v):
                    raise _Reject(6, f"joint {j} sample {int(round(v))} outside limits")
        prev = self.segments[-1].at(1.0) if self.segments else np.array(self.q)
        start = coef[:, 0]
        for j in range(self.joints):
            if abs(start[j] - prev[j]) > 50:
                raise _Reject(9, f"joint {j} starts at {int(start[j])}, previous end {int(round(prev[j]))}")
        if not self.segments:
            seg.start = self.time
            self.state = "RUN"
        self.segments.append(seg)
        return str(self.queue_depth - len(self.segments))

    def _cmd_stop(self, args):
        self._nargs(args, 0)
        self._halt()
        return " ".join(str(v) for v in self._q_int())

    def _cmd_timeout(self, args):
        self._nargs(args, 0, 1)
        if args:
            if not (args[0] == 0 or 50 <= args[0] <= 60000):
                raise _Reject(5, "timeout must be 0 or 50..60000 ms")
            self.timeout_ms = args[0]
        return str(self.timeout_ms)

    def _cmd_read(self, args):
        self._nargs(args, 0)
        return " ".join(str(a) for a in self._adc())

    def _cmd_stream(self, args):
        self._nargs(args, 1)
        if not 0 <= args[0] <= 200:
            raise _Reject(5, "rate must be 0..200 Hz")
        self.stream_hz = args[0]
        self.stream_counter = 0
        self._stream_t0 = self.time
        self._stream_k = 0
        self.stream_next = self.time if args[0] else math.inf  # first frame at once
        return str(args[0])

    def _cmd_cal(self, args):
        self._nargs(args, 1, 7)
        ch = args[0]
        if not 0 <= ch < self.channels:
            raise _Reject(5, f"channel must be 0..{self.channels - 1}")
        if len(args) == 7:
            pmin, pmax, zero, d, lo, hi = args[1:]
            if (not 400 <= pmin <= 2600 or not 400 <= pmax <= 2600 or pmin == pmax or not -36000 <= zero <= 36000
                    or d not in (1, -1) or not -36000 <= lo <= hi <= 36000 or hi > 36000):
                raise _Reject(5, "calibration field out of range")
            if self.state == "RUN":
                raise _Reject(8, "trajectory running")
            new = [pmin, pmax, zero, d, lo, hi]
            if ch < self.joints and not self._valid(ch, self.q[ch], new):
                raise _Reject(6, f"joint {ch} position {int(self.q[ch])} invalid under the new calibration")
            if ch == self.joints and not min(pmin, pmax) <= self.grip <= max(pmin, pmax):
                raise _Reject(6, "gripper pulse outside the new range")
            self.cal[ch] = new
        return " ".join(str(v) for v in [ch] + self.cal[ch])

    def _cmd_defaults(self, args):
        self._nargs(args, 0)
        if self.state == "RUN":
            raise _Reject(8, "trajectory running")
        new = [list(FACTORY) for _ in range(self.channels)]
        for j in range(self.joints):
            if not self._valid(j, self.q[j], new[j]):
                raise _Reject(6, f"joint {j} position invalid under the defaults")
        self.cal = new
        self.timeout_ms = 500
        return ""

    def _cmd_save(self, args):
        self._nargs(args, 0)
        if self.state == "RUN":
            raise _Reject(8, "trajectory running")
        img = bytearray(b"LK") + bytes([1, self.channels])
        for c in self.cal:
            img += struct.pack("<hhhbhh", *c)
        img += struct.pack("<H", self.timeout_ms)
        img += struct.pack("<H", _crc16(img))
        self.eeprom[: len(img)] = img
        return str(len(img))


def _crc16(data):
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF)."""
    crc = 0xFFFF
    for b in bytes(data):
        crc ^= b << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def make_board(robot="arduino_arm_3dof", *, seed=0, **physics):
    """A :class:`VirtualBoard` with ``PhysicsConfig(seed=seed, **physics)``."""
    return VirtualBoard(robot, replace(PhysicsConfig(), seed=int(seed), **physics))


def serve_pty(board, *, time_scale=1.0, announce=print, stop=None):
    """Serve ``board`` on a new pseudo-terminal until ``stop()`` is true (or forever).

    Board time runs at ``time_scale`` times the wall clock. ``announce`` gets the
    pty's path (the port name to open).

    Parameters
    ----------
    board : VirtualBoard
        The board to serve.
    time_scale : float
        Board seconds per wall-clock second.
    announce : callable
        Called once with the pty's path (str), e.g. ``print``.
    stop : callable, optional
        Polled about every 2 ms; serving ends when it returns true. Default:
        serve until interrupted.
    """
    import os
    import select
    import time
    import tty

    master, slave = os.openpty()
    tty.setraw(slave)
    announce(os.ttyname(slave))
    t0 = time.monotonic()
    try:
        while stop is None or not stop():
            r, _, _ = select.select([master], [], [], 0.002)
            board.advance_to((time.monotonic() - t0) * time_scale)
            if r:
                try:
                    data = os.read(master, 4096)
                except OSError:
                    data = b""
                board.receive(data)
            out = board.take_output()
            if out:
                os.write(master, out)
    finally:
        os.close(master)
        os.close(slave)


def _cmd_sim(args):
    import sys

    board = make_board(args.robot, seed=args.seed)

    def announce(path):
        print(path, flush=True)
        print(f"virtual {board.robot.name} (seed {args.seed}) on {path}; Ctrl-C to stop", file=sys.stderr, flush=True)

    try:
        serve_pty(board, time_scale=args.time_scale, announce=announce)
    except KeyboardInterrupt:
        pass
    return 0


def add_cli(subparsers):
    """Add ``labkit sim`` (serve the virtual arm on a pty and print its path).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The subcommand collection of the ``labkit`` parser
        (``parser.add_subparsers()``); see :data:`labkit.cli.PLUGINS`.
    """
    sp = subparsers.add_parser("sim", help="serve the virtual arm on a pseudo-terminal (prints the port path)")
    sp.add_argument("robot", nargs="?", default="arduino_arm_3dof", help="bundled robot name or robot file")
    sp.add_argument("--seed", type=int, default=0, help="physics seed (offsets, noise)")
    sp.add_argument("--time-scale", type=float, default=1.0, help="board seconds per wall-clock second")
    sp.set_defaults(func=_cmd_sim)
