"""The executor's request lines and commands (protocol v3, ``docs/protocol.md`` sections 2 and 4).

:class:`BoardCommands` is the half of the board's :class:`Executor` that
reads a request line (characters, optional checksum and sequence id, integer
arguments), runs its command (``HELLO``, ``MOVE``, ``SEG`` ...) on the
board's state and answers ``OK`` or ``ERR``; the rest of the executor (state, clock,
servo frames, feedback stream) is in ``_executor.py``. A rejected command has no
effect: every check comes before the first change of state. The EEPROM image
(calibration and host timeout, ``SAVE``) is written and read here too.
"""

from __future__ import annotations

import math
import struct

import numpy as np

from labkit.arm._protocol import (
    ERRORS,
    MAX_LINE,
    PROTOCOL_VERSION,
    REQUEST_CHECKSUM,
    REQUEST_INT,
    AMAX_MAX,
    CAL_FIELDS,
    REQUEST_SEQ,
    READ_ONLY,
    VMAX_FACTORY,
    VMAX_MAX,
    CommandRejected,
    checksum,
    echo,
)
from labkit.arm._segment_check import segment_position_ok, segment_speed_ok

__all__ = ["FW_VERSION"]

#: firmware version the virtual board reports (``HELLO`` ``fw=``, ``READY``)
FW_VERSION = "3.0.0"
#: accepted sealed requests the board remembers to answer a repeat without running it (docs/protocol.md 2.1)
SEEN = 4
#: commands whose reply fields report the state they left: a repeat regenerates them (the others store theirs)
_REPORTS = {"STOP": None, "CAL": 1, "LIMITS": 1, "DEFAULTS": None}
#: factory calibration of every channel: pmin, pmax [us], zero [cdeg], direction, lo, hi [cdeg]
FACTORY = (500, 2500, 0, 1, 0, 18000)
#: EEPROM image version (2: with the speed limits; 3: sealed with the line checksum, CRC-32)
EE_VERSION = 3


class _Reject(CommandRejected):
    """The board rejects the request it is handling (always caught: answered ``ERR``)."""

    def __init__(self, code, text=""):
        self.text = text
        super().__init__(f"{code} {ERRORS[code]} {text}".rstrip(), code, ERRORS[code])


class _Segment:
    __slots__ = ("dur", "coef", "rows", "start")

    def __init__(self, dur, coef):
        self.dur = dur  # [s]
        self.coef = coef  # (J, order + 1) [cdeg], normalised time
        self.rows = coef.astype(int).tolist()  # the same, as the integers received
        self.start = None

    def at(self, s):
        s = min(max(s, 0.0), 1.0)
        return np.polynomial.polynomial.polyval(s, self.coef.T)


def eeprom_image(cal, vmax, amax, timeout_ms):
    """The EEPROM image (version 3) of a calibration, speed limits and host timeout (``docs/protocol.md`` 4.6).

    Parameters
    ----------
    cal : list of list
        Per channel ``[pmin, pmax, zero, direction, lo, hi]``.
    vmax, amax : list of int
        Per joint speed [cdeg/s] and acceleration [cdeg/s^2] limits (0: unchecked).
    timeout_ms : int
        Host-silence timeout [ms].

    Returns
    -------
    bytes
    """
    img = bytearray(b"LK") + bytes([EE_VERSION, len(cal)])
    for c in cal:
        img += struct.pack("<hhhbhh", *c)
    for v, a in zip(vmax, amax):
        img += struct.pack("<II", v, a)
    img += struct.pack("<H", timeout_ms)
    img += struct.pack("<I", checksum(img))
    return bytes(img)


def read_eeprom(eeprom, channels):
    """Calibration, speed limits and host timeout stored in an EEPROM image, or the factory defaults.

    Parameters
    ----------
    eeprom : bytes-like
        EEPROM contents from address 0.
    channels : int
        Servo channels of the board (joints + 1).

    Returns
    -------
    cal : list of list
        Per channel ``[pmin, pmax, zero, direction, lo, hi]``.
    vmax, amax : list of int
        Per joint speed [cdeg/s] and acceleration [cdeg/s^2] limits (0: unchecked).
    timeout_ms : int
        Host-silence timeout [ms].
    valid : bool
        False when magic, version, channel count or CRC is wrong (the defaults are returned).
    """
    joints = channels - 1
    cal = [list(FACTORY) for _ in range(channels)]
    defaults = cal, [VMAX_FACTORY] * joints, [0] * joints, 500, False
    e = eeprom
    size = 4 + 11 * channels + 8 * joints + 2
    if e[0:2] != b"LK" or e[2] != EE_VERSION or e[3] != channels or checksum(e[:size]) != struct.unpack_from(
            "<I", e, size)[0]:
        return defaults
    off = 4
    for c in range(channels):
        cal[c] = list(struct.unpack_from("<hhhbhh", e, off))
        off += 11
    vmax, amax = [], []
    for _ in range(joints):
        v, a = struct.unpack_from("<II", e, off)
        vmax.append(v)
        amax.append(a)
        off += 8
    return cal, vmax, amax, struct.unpack_from("<H", e, off)[0], True


class BoardCommands:
    """Request-line handling and command handlers of the board's executor (a mixin of :class:`Executor`).

    Works on the executor's state (``q``, ``cal``, ``segments``, ``state``...)
    and answers through its ``_emit``; a handler ``_cmd_<name>(args)`` returns
    the reply fields or raises a rejection (code of :data:`labkit.arm.ERRORS`).
    """

    # -- request lines -------------------------------------------------------------
    def _handle(self, raw):
        if any(not (0x20 <= b <= 0x7E or b == 9) for b in raw):
            self._emit("ERR 2 SYNTAX character")
            return
        line = raw.decode("ascii").strip(" \t")
        if not line:
            return
        body = line[1:] if line.startswith("$") else line
        sealed = "*" in body
        if sealed:
            k = body.rindex("*")
            tail = body[k + 1:]
            if not REQUEST_CHECKSUM.match(tail) or len(tail) != 8:
                self._emit("ERR 1 BADCHK malformed")
                return
            if int(tail, 16) != checksum(body[:k]):
                self._emit("ERR 1 BADCHK mismatch")
                return
            body = body[:k]
        tokens = body.split()
        seq = None
        if tokens and tokens[0].startswith("#"):
            m = REQUEST_SEQ.match(tokens[0])
            if not m or int(m.group(1)) > 65535:
                self._emit("ERR 2 SYNTAX seq")
                return
            seq = int(m.group(1))
            tokens = tokens[1:]
        tag = f" #{seq}" if seq is not None else ""
        if not tokens:
            self._emit(f"ERR{tag} 2 SYNTAX command")
            return
        name = tokens[0].upper()
        handler = getattr(self, f"_cmd_{name.lower()}", None) if name.isalpha() else None
        if handler is None:
            self._emit(f"ERR{tag} 3 UNKNOWN")
            return
        if name not in READ_ONLY and (not sealed or seq is None):
            self._emit("ERR 1 BADCHK unsealed")
            return
        try:
            args = []
            for tok in tokens[1:]:
                if not REQUEST_INT.match(tok) or not -2**31 < int(tok) < 2**31:
                    raise _Reject(2, "arguments")
                args.append(int(tok))
            if len(args) > 2 + 6 * self.joints:  # more than a quintic SEG: refused before the repeat/stale checks
                raise _Reject(2, "arguments")
            key = (seq, echo(name, args)) if name not in READ_ONLY else None
            seen = next((s for s in self.seen if s[0] == key), None)
            if seen is not None:  # a repeat: answered with the original reply, not run
                fields = seen[1] if seen[1] is not None else self._report(name, args)
            else:
                if key is not None and self.window and not 1 <= (seq - self.last_seq) % 65536 <= 32767:
                    # stale: not newer than the newest accepted #seq and not a remembered repeat (a late copy)
                    raise _Reject(12, f"after #{self.last_seq}")
                fields = handler(args)
                if key is not None:
                    self.seen.append((key, None if name in _REPORTS else fields))
                    del self.seen[:-SEEN]
                    self.last_seq = seq
                    self.window = True
        except _Reject as rej:
            self._emit(f"ERR{tag} {rej}")
            return
        self.last_ok = self.time
        head = f"OK{tag} {name}"
        if name not in READ_ONLY:
            head += " " + echo(name, args)
        self._emit(head + (f" {fields}" if fields else ""))

    def _report(self, name, args):
        """The fields of a repeated STOP, CAL, LIMITS or DEFAULTS: the state they left, reported now, nothing changed."""
        if name == "STOP":
            return " ".join(str(v) for v in self._q_int())
        if name in ("CAL", "LIMITS"):
            return getattr(self, f"_cmd_{name.lower()}")(args[:1])  # their report-only form
        return ""

    @staticmethod
    def _nargs(args, *counts):
        if len(args) not in counts:
            raise _Reject(2, "arguments")

    def _not_busy(self):
        if self.state == "RUN":
            raise _Reject(8, "STOP first")

    def _cmd_hello(self, args):
        self._nargs(args, 0)
        # a new session (docs/protocol.md 2.1): the remembered requests and the stale window are forgotten
        self.seen = []
        self.window = False
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
                f"stream={self.stream_hz} flags={self.flags:02X} mem={self.mem} t={self.clock_ms} "
                f"last={self.last_seq}")

    def _check_joints(self, q, cal=None):
        for j, v in enumerate(q):
            if not self._valid(j, v, None if cal is None else cal[j]):
                raise _Reject(6, f"joint {j}")

    def _cmd_move(self, args):
        # MOVE q0 .. q(J-1) dur_ms: one rest-to-rest cubic from the commanded position
        # (c = q, 0, 3 dq, -2 dq), checked and run exactly like that SEG (docs/protocol.md 4.2)
        self._nargs(args, self.joints + 1)
        self._not_busy()
        self._check_joints(args[:self.joints])
        seg = [args[self.joints], 3]
        for q0, q1 in zip(self._q_int(), args[:self.joints]):
            seg += [q0, 0, 3 * (q1 - q0), -2 * (q1 - q0)]
        return self._cmd_seg(seg)

    def _cmd_grip(self, args):
        self._nargs(args, 1)
        if self.grip_refused:  # a board with no gripper servo to drive (a servo bus)
            raise _Reject(5, self.grip_refused)
        c = self.cal[self.joints]
        if not min(c[0], c[1]) <= args[0] <= max(c[0], c[1]):
            raise _Reject(5, "gripper")
        self.grip = args[0]
        return str(args[0])

    def _cmd_seg(self, args):
        if len(args) < 2:
            raise _Reject(2, "arguments")
        dur, order = args[0], args[1]
        if not 1 <= dur <= 60000:
            raise _Reject(5, "duration")
        if order not in (3, 5):
            raise _Reject(5, "order")
        if len(args) - 2 != self.joints * (order + 1):
            raise _Reject(2, "arguments")
        if any(abs(c) > 10_000_000 for c in args[2:]):
            raise _Reject(5, "coefficient")
        if len(self.segments) >= self.queue_depth:
            raise _Reject(7)
        rows = [args[2 + j * (order + 1):2 + (j + 1) * (order + 1)] for j in range(self.joints)]
        seg = _Segment(dur / 1000.0, np.array(rows, dtype=float))
        prev = [sum(r) for r in self.segments[-1].rows] if self.segments else self._q_int()
        for j in range(self.joints):
            # (a MOVE's cubic stays between its checked end points: its Bernstein hull passes at once; the
            # firmware skips the check)
            lo, hi = self._feasible(j)
            if lo > hi or not segment_position_ok(rows[j], lo, hi):
                raise _Reject(6, f"joint {j}")
            if abs(rows[j][0] - prev[j]) > 50:
                raise _Reject(9, f"joint {j}")
        for j in range(self.joints):
            if not segment_speed_ok(rows[j], dur, self.vmax[j], self.amax[j]):
                raise _Reject(11, f"joint {j}")
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
                raise _Reject(5, "timeout")
            self.timeout_ms = args[0]
        return str(self.timeout_ms)

    def _cmd_read(self, args):
        self._nargs(args, 0)
        return " ".join(str(a) for a in self._adc())

    def _cmd_stream(self, args):
        self._nargs(args, 1)
        if not 0 <= args[0] <= 200:
            raise _Reject(5, "rate")
        self.stream_hz = args[0]
        self.stream_counter = 0
        self._stream_t0 = self.time
        self._stream_k = 0
        self.stream_next = self.time if args[0] else math.inf  # first frame at once
        self.servos.stream_rate(args[0])
        return str(args[0])

    def _cmd_cal(self, args):
        self._nargs(args, 1, 7)
        ch = args[0]
        if not 0 <= ch < self.channels:
            raise _Reject(5, "channel")
        if len(args) == 7:
            self._not_busy()
            pmin, pmax, zero, d, lo, hi = args[1:]
            if (pmin == pmax or d == 0 or lo > hi
                    or not all(low <= v <= high for (_, low, high, _), v in zip(CAL_FIELDS, args[1:]))):
                raise _Reject(5, "calibration field")
            new = [list(c) for c in self.cal]
            new[ch] = [pmin, pmax, zero, d, lo, hi]
            self._positions_valid(new)
            self.cal[ch] = new[ch]
        return " ".join(str(v) for v in [ch] + self.cal[ch])

    def _positions_valid(self, cal):
        self._check_joints(self.q, cal)
        g = cal[self.joints]
        if not min(g[0], g[1]) <= self.grip <= max(g[0], g[1]):
            raise _Reject(6, "gripper")

    def _cmd_limits(self, args):
        self._nargs(args, 1, 3)
        j = args[0]
        if not 0 <= j < self.joints:
            raise _Reject(5, "joint")
        if len(args) == 3:
            if not (0 <= args[1] <= VMAX_MAX and 0 <= args[2] <= AMAX_MAX):
                raise _Reject(5, "limits")
            self._not_busy()
            self.vmax[j], self.amax[j] = args[1], args[2]
        return f"{j} {self.vmax[j]} {self.amax[j]}"

    def _cmd_defaults(self, args):
        self._nargs(args, 0)
        self._not_busy()
        new = [list(FACTORY) for _ in range(self.channels)]
        self._positions_valid(new)
        self.cal = new
        self.timeout_ms = 500
        return ""

    def _cmd_save(self, args):
        self._nargs(args, 0)
        self._not_busy()
        img = eeprom_image(self.cal, self.vmax, self.amax, self.timeout_ms)
        self.eeprom[: len(img)] = img
        return str(len(img))
