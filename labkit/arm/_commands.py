"""The virtual board's request lines and commands (protocol v1, ``docs/protocol.md`` sections 2 and 4).

:class:`BoardCommands` is the half of :class:`labkit.arm.VirtualBoard` that
reads a request line (characters, optional checksum and sequence id, integer
arguments), runs its command (``HELLO``, ``MOVE``, ``SEG`` ...) on the
board's state and answers ``OK`` or ``ERR``; the board itself (state, clock,
servo frames, feedback stream) is in ``_board.py``. A rejected command has no
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
    REQUEST_SEQ,
    CommandRejected,
    checksum,
    crc16,
)

__all__ = ["FW_VERSION"]

#: firmware version the virtual board reports (``HELLO`` ``fw=``, ``EV BOOT``)
FW_VERSION = "1.0.0"
#: factory calibration of every channel: pmin, pmax [us], zero [cdeg], direction, lo, hi [cdeg]
FACTORY = (500, 2500, 0, 1, 0, 18000)


class _Reject(CommandRejected):
    """The board rejects the request it is handling (always caught: answered ``ERR``)."""

    def __init__(self, code, text=""):
        self.text = text
        super().__init__(f"{code} {ERRORS[code]} {text}".rstrip(), code, ERRORS[code])


class _Segment:
    __slots__ = ("dur", "coef", "start")

    def __init__(self, dur, coef):
        self.dur = dur  # [s]
        self.coef = coef  # (J, order + 1) [cdeg], normalised time
        self.start = None

    def at(self, s):
        s = min(max(s, 0.0), 1.0)
        return np.polynomial.polynomial.polyval(s, self.coef.T)


def read_eeprom(eeprom, channels):
    """Calibration and host timeout stored in an EEPROM image, or the factory defaults.

    Parameters
    ----------
    eeprom : bytes-like
        EEPROM contents from address 0.
    channels : int
        Servo channels of the board.

    Returns
    -------
    cal : list of list
        Per channel ``[pmin, pmax, zero, direction, lo, hi]``.
    timeout_ms : int
        Host-silence timeout [ms].
    valid : bool
        False when magic, version, channel count or CRC is wrong (the defaults are returned).
    """
    cal = [list(FACTORY) for _ in range(channels)]
    e = eeprom
    size = 4 + 11 * channels + 2
    if e[0:2] != b"LK" or e[2] != 1 or e[3] != channels or crc16(e[:size]) != struct.unpack_from(
            "<H", e, size)[0]:
        return cal, 500, False
    off = 4
    for c in range(channels):
        pmin, pmax, zero, d, lo, hi = struct.unpack_from("<hhhbhh", e, off)
        cal[c] = [pmin, pmax, zero, d, lo, hi]
        off += 11
    return cal, struct.unpack_from("<H", e, off)[0], True


def eeprom_image(cal, timeout_ms):
    """The EEPROM bytes ``SAVE`` writes: magic, version, channel count, calibration, timeout, CRC.

    Parameters
    ----------
    cal : sequence of sequence of int
        Per channel ``[pmin, pmax, zero, direction, lo, hi]`` (pulses [us], angles [cdeg]).
    timeout_ms : int
        Host-silence timeout [ms].

    Returns
    -------
    bytearray
        The image, read back by :func:`read_eeprom`.
    """
    img = bytearray(b"LK") + bytes([1, len(cal)])
    for c in cal:
        img += struct.pack("<hhhbhh", *c)
    img += struct.pack("<H", int(timeout_ms))
    img += struct.pack("<H", crc16(img))
    return img


class BoardCommands:
    """Request-line handling and command handlers of :class:`labkit.arm.VirtualBoard` (a mixin).

    Works on the board's state (``q``, ``cal``, ``segments``, ``state``...)
    and answers through its ``_emit``; a handler ``_cmd_<name>(args)`` returns
    the reply fields or raises a rejection (code of :data:`labkit.arm.ERRORS`).
    """

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
            if not REQUEST_CHECKSUM.match(tail) or int(tail[:2], 16) != checksum(body[:k]):
                self._emit("ERR 1 BADCHK")
                return
            body = body[:k]
        tokens = body.split()
        if not tokens:
            return
        seq = None
        if tokens[0].startswith("#"):
            m = REQUEST_SEQ.match(tokens[0])
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
                if not REQUEST_INT.match(tok) or not -2**31 <= int(tok) < 2**31:
                    raise _Reject(2, f"malformed number {tok[:12]}")
                args.append(int(tok))
            fields = handler(args)
        except _Reject as rej:
            self._emit(f"ERR{tag} {rej}")
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
        img = eeprom_image(self.cal, self.timeout_ms)
        self.eeprom[: len(img)] = img
        return str(len(img))
