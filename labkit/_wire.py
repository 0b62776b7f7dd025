"""Wire layer of the host link (private; the public names are re-exported by :mod:`labkit.link`).

Everything between :class:`labkit.link.Arm`'s lab operations and the serial
port, in protocol v1 (``docs/protocol.md``): request lines with sequence id
and checksum, the byte stream cut into lines, checksum checks of board lines,
reply/event/feedback-frame parsing, the request/retry loop (:class:`_Wire`,
the base class of ``Arm``) and the encoding of trajectories as polynomial
segments (:func:`segments_from_trajectory`).
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass, field

import numpy as np

from labkit.exceptions import DeviceError
from labkit.sim import checksum

__all__ = ["BoardInfo", "Status", "LinkStats", "CommandRejected", "segments_from_trajectory"]


PROTOCOL_VERSION = 1
_LINE = re.compile(rb"^([\x20-\x7e]*)\*([0-9A-F]{2})$")
_NOT_EXECUTED = {1, 2, 3, 4}  # the request never ran (garbled on the way)
_STRICT_INT = re.compile(r"^(0|-?[1-9][0-9]{0,9})$")  # the board never sends "+", leading zeros or "-0"


def _int(text):
    """Parse an integer exactly as the board writes it (ValueError otherwise)."""
    if not _STRICT_INT.match(text):
        raise ValueError(f"not a board integer: {text!r}")
    return int(text)


class CommandRejected(DeviceError):
    """The board answered ``ERR``: the request had no effect. Attributes ``code``, ``name``."""

    def __init__(self, message, code, name):
        self.code = code
        self.name = name
        super().__init__(message)


class _NoReply(Exception):
    def __init__(self, why, executed=None):
        self.why = why
        self.executed = executed  # False: surely not executed; None: unknown
        super().__init__(why)


@dataclass(frozen=True)
class BoardInfo:
    """``HELLO`` answer: firmware version, protocol, joints, channels, queue depth, max line length."""

    firmware: str
    protocol: int
    joints: int
    channels: int
    queue: int
    maxline: int


@dataclass(frozen=True)
class Status:
    """``STATUS`` answer in SI units (``q`` [rad], ``t`` [s], ``timeout`` [s])."""

    state: str
    q: np.ndarray
    grip_us: int
    queue: int
    free: int
    done: int
    timeout: float
    stream_hz: int
    flags: int
    mem: int
    t: float


@dataclass
class LinkStats:
    """Counters of everything that went wrong on the wire (nothing is hidden)."""

    sent: int = 0
    replies: int = 0
    bad_lines: int = 0
    timeouts: int = 0
    retries: int = 0
    verified: int = 0
    frames: int = 0
    lost_frames: int = 0
    rejected_frames: int = 0



@dataclass
class _Line:
    kind: str  # OK, ERR, EV, FB
    seq: int | None
    tokens: list = field(default_factory=list)


def _parse_hello(fields):
    """``HELLO`` reply fields -> :class:`BoardInfo` (the joined text if it is not a labkit arm)."""
    kv = dict(tok.split("=", 1) for tok in fields[1:] if "=" in tok)
    if fields[:1] != ["labkit-arm"]:
        return " ".join(fields)
    return BoardInfo(kv["fw"], _int(kv["proto"]), _int(kv["joints"]), _int(kv["channels"]),
                     _int(kv["queue"]), _int(kv["maxline"]))


def _parse_read(fields, n):
    """``READ`` reply fields -> ADC counts of ``n`` joints and the user pot, shape (n + 1,)."""
    vals = [_int(v) for v in fields]
    if len(vals) != n + 1 or not all(0 <= v <= 1023 for v in vals):
        raise ValueError(f"expected {n + 1} counts 0..1023")
    return np.array(vals)


def _parse_stop(fields, n):
    """``STOP`` reply fields -> the ``n`` held joint values [rad] (sent in centidegrees)."""
    if len(fields) != n:
        raise ValueError(f"expected {n} joint values")
    return np.radians(np.array([_int(v) for v in fields]) / 100.0)


def _cdeg(q):
    """Joint value [rad] -> integer centidegrees, the protocol's angle unit."""
    return int(round(math.degrees(float(q)) * 100))


def _hermite(q0, v0, a0, q1, v1, a1, T, order):
    """Normalised-time polynomial coefficients [cdeg] of one joint over ``T`` s (end point exact)."""
    d0, d1 = math.degrees(q0) * 100, math.degrees(q1) * 100
    v0, v1 = math.degrees(v0) * 100 * T, math.degrees(v1) * 100 * T
    if order == 3:
        c = [d0, v0, 3 * (d1 - d0) - 2 * v0 - v1, -2 * (d1 - d0) + v0 + v1]
    else:
        a0, a1 = math.degrees(a0) * 100 * T * T, math.degrees(a1) * 100 * T * T
        h = d1 - d0
        c = [d0, v0, a0 / 2, 10 * h - 6 * v0 - 4 * v1 - 1.5 * a0 + 0.5 * a1,
             -15 * h + 8 * v0 + 7 * v1 + 1.5 * a0 - a1, 6 * h - 3 * v0 - 3 * v1 - 0.5 * a0 + 0.5 * a1]
    c = [int(round(v)) for v in c]
    c[-1] = int(round(d1)) - sum(c[:-1])
    return c


def segments_from_trajectory(traj, *, order=3, min_duration=0.05):
    """Protocol segments ``(dur_ms, order, coefficients)`` of a sampled trajectory.

    Consecutive samples (merged until at least ``min_duration`` apart) become
    one Hermite polynomial each, matching position and velocity (and
    acceleration for ``order=5``) at both ends; coefficients are integer
    centidegrees over normalised time, the end point of each segment is the
    exact start of the next.

    Parameters
    ----------
    traj : labkit.trajectory.Trajectory
        Samples ``t`` (m,), ``q``/``qd``/``qdd`` (m, n) [s, rad, rad/s, rad/s^2].
    order : {3, 5}
    min_duration : float
        Shortest segment [s].

    Returns
    -------
    list of tuple
        ``(dur_ms, order, coefficients)`` with ``n * (order + 1)`` coefficients.
    """
    if order not in (3, 5):
        raise ValueError(f"expected order 3 or 5, got {order!r}")
    t = np.asarray(traj.t, float)
    q, qd = np.asarray(traj.q, float), np.asarray(traj.qd, float)
    qdd = np.asarray(traj.qdd, float) if traj.qdd is not None else np.zeros_like(q)
    keep = [0]
    for k in range(1, len(t)):
        if t[k] - t[keep[-1]] >= min_duration - 1e-9 or k == len(t) - 1:
            keep.append(k)
    segs = []
    for a, b in zip(keep[:-1], keep[1:]):
        T = round((t[b] - t[a]) * 1000) / 1000
        if T <= 0:
            continue
        coef = []
        for j in range(q.shape[1]):
            coef += _hermite(q[a, j], qd[a, j], qdd[a, j], q[b, j], qd[b, j], qdd[b, j], T, order)
        segs.append((int(round(T * 1000)), order, coef))
    return segs


class _Wire:
    """Byte, line and request layer of :class:`labkit.link.Arm` (its base class).

    Owns the link state: ``robot`` (joint count, feedback slew limits),
    reply ``timeout`` [s], ``retries``, ``stats`` (:class:`LinkStats`),
    ``events`` (``EV`` lines received) and the line/frame buffers. The
    subclass opens ``port`` and sets ``name`` (and ``info`` after the
    handshake).

    Parameters
    ----------
    robot : labkit.dh.Robot
        The loaded robot file.
    timeout : float
        Reply timeout of one request attempt [s].
    retries : int
        Extra attempts of a request whose reply was lost or garbled.
    """

    def __init__(self, robot, *, timeout, retries):
        self.robot = robot
        self.timeout = float(timeout)
        self.retries = int(retries)
        self.stats = LinkStats()
        self.events = []
        self._seq = 0
        self._buf = bytearray()
        self._lines = []
        self._frames = None
        self._booted = False
        # largest feedback change per second [counts/s]: joint speed limit x ADC gain, 1.5x margin
        self._adc_slew = np.array([
            1.5 * (lk.max_velocity if math.isfinite(lk.max_velocity) else math.radians(600))
            * abs(float(lk.servo.adc_from_joint(1.0) - lk.servo.adc_from_joint(0.0))) if lk.servo else np.inf
            for lk in self.robot.links])

    # -- time --------------------------------------------------------------------------
    def _clock(self):
        """Board time [s] for a simulated board (``sim://``), else the wall clock.

        All waits and timeouts of the link are in these seconds, so a virtual arm
        running faster than real time keeps its timing.
        """
        board = getattr(self.port, "board", None)
        if board is None:
            return time.monotonic()
        if getattr(self.port, "clock", "") == "realtime":
            self._io(lambda: self.port.in_waiting)  # brings the board up to date
        return board.time

    def _port_seconds(self, seconds):
        """Read timeout for the port that lets ``seconds`` of :meth:`_clock` pass."""
        if getattr(self.port, "clock", "") == "realtime":
            return seconds / self.port.time_scale
        return seconds

    # -- bytes and lines ---------------------------------------------------------------------
    def _io(self, fn, *args):
        import serial

        if self.port is None:
            raise DeviceError("the link is closed")
        try:
            return fn(*args)
        except (serial.SerialException, OSError) as exc:
            raise DeviceError(f"{self.name}: port vanished or failed: {exc}") from None

    def _send(self, text):
        data = text.encode("ascii")
        self._io(self.port.write, data)
        self.stats.sent += 1

    def _pump(self, timeout):
        """Read for up to ``timeout`` s (returns early once a line has arrived)."""
        port = self.port
        port.timeout = max(self._port_seconds(timeout), 0.0)
        waiting = self._io(lambda: port.in_waiting)
        chunk = self._io(port.read, max(1, waiting))
        if not chunk:
            return False
        self._buf += chunk
        got = False
        while True:
            k = min((i for i in (self._buf.find(b"\n"), self._buf.find(b"\r")) if i >= 0), default=-1)
            if k < 0:
                if len(self._buf) > 4 * 160:
                    self._buf.clear()
                    self.stats.bad_lines += 1
                break
            raw = bytes(self._buf[:k])
            del self._buf[:k + 1]
            if raw:
                self._dispatch(raw)
                got = True
        return got

    def _dispatch(self, raw):
        m = _LINE.match(raw)
        if not m or int(m.group(2), 16) != checksum(m.group(1)):
            self.stats.bad_lines += 1
            return
        tokens = m.group(1).decode("ascii").split()
        kind = tokens[0] if tokens else ""
        if kind == "FB":
            self._frame(tokens)
            return
        if kind == "EV" and len(tokens) >= 2:
            if tokens[1] == "BOOT":
                if self._booted and hasattr(self, "info"):
                    self.events.append(("BOOT-UNEXPECTED", tokens[2:]))
                self._booted = True
            self.events.append((tokens[1], tokens[2:]))
            return
        if kind in ("OK", "ERR") and len(tokens) >= 2:
            seq = None
            if tokens[1].startswith("#"):
                if not _STRICT_INT.match(tokens[1][1:]):
                    self.stats.bad_lines += 1
                    return
                seq = int(tokens[1][1:])
                tokens = [kind] + tokens[2:]
            self._lines.append(_Line(kind, seq, tokens))
            return
        self.stats.bad_lines += 1

    def _consistent(self, a, b):
        """Can frame ``b`` follow frame ``a`` (counters, board times, joint speeds)?"""
        st = self._frames
        gap = (b[0] - a[0]) % 65536
        if not 1 <= gap < 65536 // 2:
            return False
        # the firmware stamps a frame when it sends it: a few ms of jitter, never drift
        if abs((b[1] - a[1]) - gap * 1000.0 / st["hz"]) > 2.0 + 250.0 / st["hz"]:
            return False
        # joints cannot jump: a dropped digit (invisible to the XOR checksum) changes a value a lot
        J = self.robot.n
        step = np.abs(np.array(b[2:2 + J]) - np.array(a[2:2 + J]))
        return bool(np.all(step <= self._adc_slew * gap / st["hz"] + 12))

    def _frame(self, tokens):
        """Accept a feedback frame only when a neighbouring frame confirms it."""
        st = self._frames
        if st is None:
            return
        try:
            vals = tuple(_int(v) for v in tokens[1:])
        except ValueError:
            vals = ()
        J = self.robot.n
        if not (len(vals) == J + 3 and 0 <= vals[0] <= 65535 and all(0 <= a <= 1023 for a in vals[2:])):
            self.stats.rejected_frames += 1
            return
        accept = []
        anchor, pending = st["last"], st["pending"]
        if anchor is not None and self._consistent(anchor, vals):
            accept = [vals]
        elif pending is not None and self._consistent(pending, vals):
            accept = [pending, vals]  # two frames that agree: (re-)anchor on them
        st["pending"] = None if accept else vals
        if pending is not None and not accept:
            self.stats.rejected_frames += 1
        for v in accept:
            st["rows"].append((time.time(), *v))
            st["last"] = v
            self.stats.frames += 1

    # -- requests ----------------------------------------------------------------------------
    def _next_seq(self):
        self._seq = (self._seq % 65535) + 1
        return self._seq

    def _await(self, seq):
        deadline = self._clock() + self.timeout
        while True:
            for k, ln in enumerate(self._lines):
                if ln.seq == seq or (ln.kind == "ERR" and ln.seq is None):
                    del self._lines[k]
                    if ln.seq is None:
                        code = int(ln.tokens[1]) if ln.tokens[1:2] and ln.tokens[1].isdigit() else 0
                        raise _NoReply(f"board reported a garbled request (ERR {code})",
                                       executed=False if code in _NOT_EXECUTED else None)
                    return ln
            self._lines.clear()  # stale replies to earlier attempts
            left = deadline - self._clock()
            if left <= 0:
                self.stats.timeouts += 1
                raise _NoReply(f"no valid reply within {self.timeout:g} s")
            self._pump(left)

    def _drain(self):
        """Handle every line already received; forget unanswered replies (stale by now)."""
        while self._io(lambda: self.port.in_waiting):
            self._pump(0.0)
        self._lines.clear()

    def _transact(self, command, *args, motion=False, verify=None, parse=None, retries=None):
        """Send one request until it is acknowledged; return the (parsed) reply."""
        if any(k == "BOOT-UNEXPECTED" for k, _ in self.events):
            raise DeviceError(f"{self.name}: the board reset itself (EV BOOT); its state is lost - reconnect")
        last = None
        rejected = set()
        retries = self.retries if retries is None else retries
        for attempt in range(retries + 1):
            self._drain()
            seq = self._next_seq()
            body = " ".join([f"#{seq}", command, *(str(int(a)) for a in args)])
            # the space before "*" makes a line whose "*" is lost fail the argument count
            # instead of running with the checksum digits glued to its last number
            body += " "
            self._send(("\n" if attempt else "") + f"{body}*{checksum(body):02X}\n")
            try:
                reply = self._await(seq)
            except _NoReply as exc:
                last = exc
                self.stats.retries += attempt < retries
                if motion:  # even "garbled" may be a stale reply to an earlier line: ask the board
                    if verify():
                        self.stats.verified += 1
                        return _Line("OK", seq, ["OK", command])
                continue
            self.stats.replies += 1
            if reply.kind == "OK":
                if reply.tokens[1:2] != [command]:
                    last = _NoReply(f"reply names {reply.tokens[1:2]}, expected {command}")
                    continue
                if parse is None:
                    return reply
                try:
                    return parse(reply.tokens[2:])
                except (ValueError, KeyError, IndexError) as exc:  # passed the weak checksum, still garbled
                    self.stats.bad_lines += 1
                    last = _NoReply(f"malformed {command} reply {' '.join(reply.tokens)!r} ({exc})")
                    if motion:
                        return reply  # acknowledged; only the extra fields are unusable
                    continue
            code = int(reply.tokens[1]) if len(reply.tokens) > 1 and reply.tokens[1].isdigit() else 0
            if code in (2, 3) or (code not in (7, 8) and code not in rejected):
                # labkit never sends bad syntax, and it checks ranges and limits before sending: the
                # line was probably corrupted in transit (the XOR checksum misses some damage). A
                # rejected request had no effect, so sending it again repeats nothing; a genuine
                # rejection comes back the same way and is raised below.
                rejected.add(code)
                last = _NoReply(" ".join(reply.tokens))
                continue
            name = reply.tokens[2] if len(reply.tokens) > 2 else "?"
            raise CommandRejected(f"{self.name}: {command} rejected: {' '.join(reply.tokens[1:])}", code, name)
        raise DeviceError(f"{self.name}: {command} failed after {retries + 1} attempts: {last}")

    def _parse_status(self, fields):
        kv = dict(tok.split("=", 1) for tok in fields)
        q = [_int(v) for v in kv["q"].split(",")]
        if len(q) != self.robot.n or kv["state"] not in ("IDLE", "RUN", "HOLD"):
            raise ValueError("bad q or state")
        if not re.fullmatch(r"[0-9A-Fa-f]{1,8}", kv["flags"]):
            raise ValueError("bad flags")
        st = Status(kv["state"], np.radians(np.array(q) / 100.0), _int(kv["grip"]), _int(kv["queue"]),
                    _int(kv["free"]), _int(kv["done"]), _int(kv["timeout"]) / 1000.0, _int(kv["stream"]),
                    int(kv["flags"], 16), _int(kv["mem"]), _int(kv["t"]) / 1000.0)
        if hasattr(self, "info") and st.queue + st.free != self.info.queue:
            raise ValueError("queue + free != queue depth")
        return st
