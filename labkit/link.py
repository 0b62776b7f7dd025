"""Host link to the arm: a pyserial client of protocol v1 (``docs/protocol.md``).

:class:`Arm` opens a real board (``/dev/ttyACM0``, ``COM3``, auto-detected),
the virtual arm (``sim://``) or the firmware simulator (``simavr://``),
waits out the reset-on-open, shakes hands, and offers the lab operations in SI
units: joint moves (checked against the robot file's limits and servo ranges
*before* anything is sent), Cartesian moves through :func:`labkit.ik.ik`,
trajectories streamed as polynomial segments, gripper, stop, joint read-back
and feedback streams into pandas.

Reliability rules (``docs/link.md``): every request carries a sequence id and
a checksum; board lines with a bad checksum or an implausible content are
dropped and counted, never used; idempotent requests are retried; a motion
request (``MOVE``, ``SEG``) whose reply is lost is never blindly repeated: the
host asks ``STATUS`` whether it was executed and resends only if it was not;
anything that cannot be settled raises :class:`~labkit.exceptions.DeviceError`.

Examples
--------
>>> with Arm("sim://?clock=lockstep") as arm:
...     arm.move_joints([0.5, 0.8, 0.3], wait=True)
...     q = arm.read_joints()
>>> np.allclose(q, [0.5, 0.8, 0.3], atol=0.02)
True
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass, field

import numpy as np

from labkit._validation import as_vector
from labkit.dh import Robot
from labkit.exceptions import DeviceError, JointLimitError, ProtocolError
from labkit.sim import checksum

__all__ = ["Arm", "Link", "BoardInfo", "Status", "LinkStats", "CommandRejected", "TrajectoryReport",
           "find_ports", "segments_from_trajectory"]

PROTOCOL_VERSION = 1
_ARDUINO_VIDS = {0x2341, 0x2A03, 0x1A86, 0x0403, 0x10C4, 0x239A}
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


@dataclass(frozen=True)
class TrajectoryReport:
    """Outcome of :meth:`Arm.run_trajectory`: segments sent, retries, underruns, board time [s]."""

    segments: int
    retries: int
    queue_full_waits: int
    underruns: int
    duration: float


@dataclass
class _Line:
    kind: str  # OK, ERR, EV, FB
    seq: int | None
    tokens: list = field(default_factory=list)


def find_ports():
    """Serial ports that look like an Arduino (USB VID or description), best first.

    Returns
    -------
    list of str
        Device names (``/dev/ttyACM0``, ``COM3`` ...).
    """
    from serial.tools import list_ports

    found = []
    for p in list_ports.comports():
        text = f"{p.description} {p.manufacturer or ''}".lower()
        if p.vid in _ARDUINO_VIDS or "arduino" in text or "ch340" in text:
            found.append(p.device)
    return sorted(found, key=lambda d: ("ACM" not in d, d))


def _cdeg(q):
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


class Arm:
    """A connection to a labkit arm board (real, virtual or simulated firmware).

    Parameters
    ----------
    port : str or serial-like, optional
        Device name (``/dev/ttyACM0``, ``COM3``), URL (``sim://``,
        ``simavr://``, any pyserial URL) or an open pyserial-like object;
        ``None`` auto-detects an Arduino-like port (:func:`find_ports`).
    robot : Robot or str
        The robot file whose servo calibrations and limits the host enforces.
    baudrate : int
    timeout : float
        Reply timeout of one request attempt [s].
    retries : int
        Extra attempts of a request whose reply was lost or garbled.
    boot_wait : float
        How long to wait for the board's ``EV BOOT`` after opening [s].
    sync_calibration : bool
        Send the robot file's servo calibrations (``CAL``) after the handshake.
    check_moves : bool
        After each acknowledged ``MOVE``, read the commanded joints back with
        ``STATUS`` and raise if they differ from what was sent.

    Raises
    ------
    DeviceError
        No port found, the port cannot be opened, no handshake, wrong protocol
        version or joint count.
    """

    def __init__(self, port=None, robot="arduino_arm_3dof", *, baudrate=115200, timeout=0.25, retries=6,
                 boot_wait=2.5, sync_calibration=True, check_moves=True):
        self.robot = Robot.load(robot)
        self.timeout = float(timeout)
        self.retries = int(retries)
        self.stats = LinkStats()
        #: read the commanded joints back after every MOVE (protocol v1 cannot detect every corrupted line)
        self.check_moves = bool(check_moves)
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
        self.port = self._open(port, baudrate)
        self.name = getattr(self.port, "port", None) or getattr(self.port, "name", repr(self.port))
        try:
            self._handshake(boot_wait)
            if sync_calibration:
                self.sync_calibration()
        except BaseException:
            self.close()
            raise

    # -- opening ------------------------------------------------------------------------
    @staticmethod
    def _open(port, baudrate):
        import serial

        from labkit.urlhandler import register

        register()
        if port is not None and not isinstance(port, (str, bytes)):
            return port
        if port is None:
            ports = find_ports()
            if not ports:
                raise DeviceError("no Arduino-like serial port found; plug the board in, name the port "
                                  "(e.g. '/dev/ttyACM0', 'COM3'), or use the virtual arm 'sim://'")
            port = ports[0]
        try:
            return serial.serial_for_url(port, baudrate=baudrate, timeout=0.05)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise DeviceError(f"cannot open {port!r}: {exc}") from None

    def _handshake(self, boot_wait):
        deadline = self._clock() + boot_wait
        while not self._booted and self._clock() < deadline:
            self._pump(0.05)
        self._lines = [ln for ln in self._lines if ln.kind != "ERR"]
        def parse(fields):
            kv = dict(tok.split("=", 1) for tok in fields[1:] if "=" in tok)
            if fields[:1] != ["labkit-arm"]:
                return " ".join(fields)
            return BoardInfo(kv["fw"], _int(kv["proto"]), _int(kv["joints"]), _int(kv["channels"]),
                             _int(kv["queue"]), _int(kv["maxline"]))

        try:
            info = self._transact("HELLO", parse=parse)
        except DeviceError as exc:
            raise DeviceError(f"{self.name}: no handshake with the board ({exc})") from None
        if not isinstance(info, BoardInfo):
            raise ProtocolError(f"{self.name}: not a labkit arm: HELLO answered {info!r}")
        self.info = info
        if self.info.protocol != PROTOCOL_VERSION:
            raise DeviceError(f"{self.name}: board speaks protocol {self.info.protocol}, "
                              f"labkit expects {PROTOCOL_VERSION}; update the firmware or labkit")
        if self.info.joints != self.robot.n:
            raise DeviceError(f"{self.name}: board has {self.info.joints} joints, robot "
                              f"{self.robot.name} has {self.robot.n}")

    def close(self):
        """Close the port (never raises, even if the port has vanished)."""
        port, self.port = getattr(self, "port", None), None
        if port is not None:
            try:
                port.close()
            except Exception:  # noqa: BLE001 - closing a vanished port must not raise
                pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        return f"Arm({self.name!r}, robot={self.robot.name!r})"

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

    def sleep(self, seconds):
        """Wait ``seconds`` of board time while handling incoming lines.

        Parameters
        ----------
        seconds : float
            Time to wait [s] (board clock: simulated time on a virtual arm).
        """
        end = self._clock() + seconds
        while (left := end - self._clock()) > 0:
            self._pump(min(left, 0.05))

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

    # -- queries -----------------------------------------------------------------------------
    def ping(self):
        """Board clock [s] (also keeps the host-silence timer alive).

        Returns
        -------
        float
            Board time since reset [s] (millisecond resolution).

        Raises
        ------
        DeviceError
            No valid reply after all retries.
        """
        return self._transact("PING", parse=lambda f: _int(f[0]) / 1000.0 if len(f) == 1 else _int("x"))

    def status(self, *, retries=None):
        """The board's state (commanded joints, queue, counters) as a :class:`Status`.

        Parameters
        ----------
        retries : int, optional
            Resend attempts after a lost or garbled reply; default ``self.retries``.

        Returns
        -------
        Status

        Raises
        ------
        DeviceError
            No valid reply after all retries.
        """
        return self._transact("STATUS", parse=self._parse_status, retries=retries)

    def _verify_status(self):
        # settling whether a motion request ran is worth a larger retry budget
        return self.status(retries=4 * self.retries + 4)

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

    def commanded_joints(self):
        """Joint values the servos are commanded to now, shape (n,) [rad].

        Returns
        -------
        ndarray, shape (n,)
            Commanded joint values [rad] (from :meth:`status`).
        """
        return self.status().q

    def read_adc(self):
        """Raw feedback counts of every joint and the user pot (``READ``), shape (n + 1,).

        Returns
        -------
        ndarray of int, shape (n + 1,)
            ADC counts 0..1023 of joints 1..n, then the user pot.

        Raises
        ------
        DeviceError
            No valid reply after all retries.
        """
        def parse(fields):
            vals = [_int(v) for v in fields]
            if len(vals) != self.robot.n + 1 or not all(0 <= v <= 1023 for v in vals):
                raise ValueError(f"expected {self.robot.n + 1} counts 0..1023")
            return np.array(vals)

        return self._transact("READ", parse=parse)

    def read_joints(self):
        """Joint values sensed by the feedback pots, shape (n,) [rad].

        Returns
        -------
        ndarray, shape (n,)
            Sensed joint values [rad], from :meth:`read_adc` through each joint's
            servo calibration.
        """
        adc = self.read_adc()
        return np.array([float(lk.servo.joint_from_adc(adc[j])) for j, lk in enumerate(self.robot.links)])

    # -- configuration ---------------------------------------------------------------------
    def sync_calibration(self):
        """Send every servo calibration of the robot file to the board (``CAL``, RAM only)."""
        for j, lk in enumerate(self.robot.links):
            cal = lk.servo
            if cal is None:
                continue
            lo_a, hi_a = cal.angle_range
            p0, p1 = cal.pulse_range
            pmin = round(p0 + (0.0 - lo_a) / (hi_a - lo_a) * (p1 - p0))
            pmax = round(p0 + (math.pi - lo_a) / (hi_a - lo_a) * (p1 - p0))
            lo, hi = (_cdeg(v) for v in lk.limits)
            self._transact("CAL", cal.channel, pmin, pmax, _cdeg(cal.zero), cal.direction, lo, hi)
        g = self.robot.gripper
        if g is not None:
            self._transact("CAL", g.channel, min(g.open_us, g.closed_us), max(g.open_us, g.closed_us), 0, 1, 0, 18000)

    def set_host_timeout(self, seconds):
        """Host-silence timeout of the board [s] (0 disables it).

        Parameters
        ----------
        seconds : float
            Time without a host line after which the board holds [s]; sent
            rounded to ms; 0 disables the timeout.
        """
        self._transact("TIMEOUT", int(round(seconds * 1000)))

    # -- motion ----------------------------------------------------------------------------
    def _check_q(self, q):
        q = as_vector(q, self.robot.n, "q")
        if q.ndim != 1:
            raise JointLimitError(f"expected one configuration q with shape ({self.robot.n},), got {q.shape}")
        self.robot.check_limits(q)
        for j, lk in enumerate(self.robot.links):
            if lk.servo is not None:
                try:
                    lk.servo.pulse_us(q[j])
                except JointLimitError as exc:
                    raise JointLimitError(f"{self.robot.name}: joint {j + 1}: {exc}", joint=j) from None
        return q

    def move_joints(self, q, *, wait=False, tol=math.radians(1.0), max_wait=10.0):
        """Command all joints at once (``MOVE``).

        Parameters
        ----------
        q : array_like, shape (n,)
            Joint values [rad]; checked against the joint limits and servo
            ranges before anything is sent.
        wait : bool
            Wait until the sensed joints are within ``tol`` [rad] of ``q``
            (at most ``max_wait`` s).
        tol : float
            Settling tolerance per joint [rad] when ``wait``.
        max_wait : float
            Longest wait for settling [s of board time] when ``wait``.

        Raises
        ------
        JointLimitError
            A joint outside its limits or servo range (nothing is sent).
        DeviceError
            The board rejected or did not acknowledge the move, or (``wait``) the
            joints did not settle in time.
        """
        q = self._check_q(q)
        target = [_cdeg(v) for v in q]

        def verify():
            return [_cdeg(v) for v in self._verify_status().q] == target

        self._transact("MOVE", *target, motion=True, verify=verify)
        if self.check_moves and not verify():
            raise DeviceError(f"{self.name}: the board is commanded to {self.status().q} rad, not the "
                              f"{q} rad sent (a line corrupted in transit executed?) - check the arm")
        if wait:
            self.wait_settled(q, tol=tol, max_wait=max_wait)

    def wait_settled(self, q, *, tol=math.radians(1.0), max_wait=10.0, interval=0.05):
        """Wait until the sensed joints stay within ``tol`` of ``q`` [rad] for two reads; returns them.

        Parameters
        ----------
        q : array_like, shape (n,)
            Target joint values [rad].
        tol : float
            Largest allowed ``|sensed - q|`` per joint [rad].
        max_wait : float
            Give up after this much board time [s].
        interval : float
            Board time between reads [s].

        Returns
        -------
        ndarray, shape (n,)
            The last sensed joint values [rad].

        Raises
        ------
        DeviceError
            The joints did not settle within ``max_wait``.
        """
        end = self._clock() + max_wait
        hits = 0
        while self._clock() < end:
            sensed = self.read_joints()
            hits = hits + 1 if np.all(np.abs(sensed - q) <= tol) else 0
            if hits >= 2:
                return sensed
            self.sleep(interval)
        raise DeviceError(f"{self.name}: joints did not settle within {max_wait} s at tolerance "
                          f"{math.degrees(tol):.2f} deg (sensed {np.degrees(sensed).round(2)} deg)")

    def move_to(self, target, *, branch=None, wait=False):
        """Move the tool to a Cartesian ``target`` through :func:`labkit.ik.ik` (nearest branch by default).

        Parameters
        ----------
        target : array_like
            Tool target for :func:`labkit.ik.ik`: position (3,) [m] for the
            3-DOF arm.
        branch : str, optional
            IK branch (e.g. ``"elbow_up"``); default: the solution nearest the
            commanded joints.
        wait : bool
            Wait until the joints settle (see :meth:`move_joints`).

        Returns
        -------
        ndarray, shape (n,)
            The joint values commanded [rad].

        Raises
        ------
        UnreachableError
            The target is out of reach (nothing is sent).
        JointLimitError, DeviceError
            As for :meth:`move_joints`.
        """
        from labkit.ik import ik

        current = self.commanded_joints()
        q = ik(self.robot, target, branch=branch, q_near=None if branch else current)
        self.move_joints(q, wait=wait)
        return q

    def grip(self, us):
        """Gripper pulse width [us].

        Parameters
        ----------
        us : float
            Pulse width sent to the gripper servo [us] (rounded to an integer).
        """
        self._transact("GRIP", int(round(us)))

    def open_gripper(self):
        """Open the gripper (robot file's ``open_us``)."""
        self.grip(self._gripper().open_us)

    def close_gripper(self):
        """Close the gripper (robot file's ``closed_us``)."""
        self.grip(self._gripper().closed_us)

    def _gripper(self):
        if self.robot.gripper is None:
            raise DeviceError(f"robot {self.robot.name} has no gripper in its robot file")
        return self.robot.gripper

    def stop(self):
        """Stop at once: end any trajectory, clear the queue, hold; returns the held joints [rad].

        Returns
        -------
        ndarray, shape (n,)
            Joint values the board holds [rad] (centidegree resolution).

        Raises
        ------
        DeviceError
            No valid reply after all retries.
        """
        def parse(fields):
            if len(fields) != self.robot.n:
                raise ValueError(f"expected {self.robot.n} joint values")
            return np.radians(np.array([_int(v) for v in fields]) / 100.0)

        return self._transact("STOP", parse=parse)

    def run_trajectory(self, traj, *, order=3, min_duration=0.05, progress=None, wait=True):
        """Stream a trajectory to the board's segment queue, keeping it fed.

        Parameters
        ----------
        traj : labkit.trajectory.Trajectory or list of segments
            A sampled trajectory (checked against the joint limits first) or
            ``(dur_ms, order, coefficients)`` tuples from
            :func:`segments_from_trajectory`.
        order : {3, 5}
            Polynomial order of the segments made from a sampled trajectory.
        min_duration : float
            Shortest segment made from a sampled trajectory [s].
        progress : callable or bool, optional
            ``progress(done, total)`` after each queued segment, or ``True`` for a tqdm bar.
        wait : bool
            Wait for the board's ``EV DONE`` after the last segment.

        Returns
        -------
        TrajectoryReport

        Raises
        ------
        JointLimitError
            A sample outside the joint limits or servo ranges (nothing is sent).
        DeviceError
            A segment rejected or lost, or the board held (host-silence timeout).
        """
        if isinstance(traj, (list, tuple)):
            segs = list(traj)
        else:
            self.robot.check_limits(np.asarray(traj.q))
            for row in np.asarray(traj.q):
                self._check_q(row)
            segs = segments_from_trajectory(traj, order=order, min_duration=min_duration)
        bar = None
        if progress is True:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(segs), unit="seg")
            progress = lambda k, n: bar.update(1)  # noqa: E731
        st = self.status()
        accepted = st.done + st.queue
        t_start = st.t
        retries0, qfull, underruns = self.stats.retries, 0, 0
        dones_seen = len([e for e in self.events if e[0] == "DONE"])
        for k, (dur, order_k, coef) in enumerate(segs):
            def verify(expected=accepted):
                s = self._verify_status()
                if s.state == "HOLD":
                    raise DeviceError(f"{self.name}: the board halted the trajectory (host-silence timeout)")
                total = s.done + s.queue
                if total not in (expected, expected + 1):
                    raise DeviceError(f"{self.name}: segment bookkeeping lost (board {total}, host {expected})")
                return total == expected + 1

            while True:
                try:
                    r = self._transact("SEG", dur, order_k, *coef, motion=True, verify=verify)
                    break
                except CommandRejected as exc:
                    if exc.code != 7:
                        raise
                    qfull += 1
                    self.sleep(min(dur / 2000.0, 0.1))
                    self.ping()  # a rejected SEG does not reset the board's host-silence timer
            accepted += 1
            if len([e for e in self.events if e[0] == "DONE"]) > dones_seen and k < len(segs):
                underruns += 1
                dones_seen = len([e for e in self.events if e[0] == "DONE"])
            if progress:
                progress(k + 1, len(segs))
            free = int(r.tokens[2]) if len(r.tokens) > 2 and r.tokens[2].isdigit() else 1
            if free == 0:
                self.sleep(min(dur / 1000.0, 0.1))
                self.ping()
        if bar is not None:
            bar.close()
        if wait:
            end_needed = accepted
            while True:
                st = self.status()
                if st.state == "HOLD":
                    raise DeviceError(f"{self.name}: the board halted the trajectory (host-silence timeout)")
                if st.state == "IDLE" and st.done >= end_needed:
                    break
                self.sleep(0.1)
        return TrajectoryReport(len(segs), self.stats.retries - retries0, qfull, underruns,
                                self.status().t - t_start if wait else float("nan"))

    # -- feedback ---------------------------------------------------------------------------
    def stream(self, duration, *, hz=50):
        """Record the feedback stream for ``duration`` seconds of board time.

        Parameters
        ----------
        duration : float
            Recording time [s of board time].
        hz : int
            Frame rate the board streams at [Hz], 1..200.

        Returns
        -------
        pandas.DataFrame
            One row per frame received intact: ``t`` [s, board clock],
            ``counter``, ``received`` (host UTC timestamp), ``adc<i>``,
            ``pot`` and the sensed joints ``q_<name>`` [rad]. ``df.attrs``
            holds ``expected`` (frames the board sent in the window, from its
            clock), ``lost`` (expected but not received intact), ``rejected``
            (lines dropped as corrupt while streaming) and ``hz``.

        Raises
        ------
        ValueError
            ``hz`` outside 1..200.
        """
        import pandas as pd

        hz = int(hz)
        if not 1 <= hz <= 200:
            raise ValueError(f"expected hz in 1..200, got {hz}")
        rejected0 = self.stats.rejected_frames + self.stats.bad_lines
        t_begin = self.ping()
        self._frames = {"hz": hz, "last": None, "pending": None, "rows": []}
        try:
            self._transact("STREAM", hz)
            t_end = self._clock() + duration
            while self._clock() < t_end:
                self._pump(min(t_end - self._clock(), 0.05))
            t_stop = self.ping()  # every frame stamped before this arrived before its reply
            self._transact("STREAM", 0)
        finally:
            st, self._frames = self._frames, None
        t_stop_ms = round(t_stop * 1000)
        rows = [r for r in st["rows"] if r[2] < t_stop_ms]
        # frames the board sent before t_stop: counter 0 at t0, one every 1/hz
        t0_ms = rows[0][2] - rows[0][1] * 1000.0 / hz if rows else t_begin * 1000
        expected = max(0, math.ceil((t_stop_ms - t0_ms) * hz / 1000.0 - 1e-6))
        lost = expected - len(rows)
        self.stats.lost_frames += lost
        if st["pending"] is not None:
            self.stats.rejected_frames += 1  # never confirmed
        J = self.robot.n
        cols = ["received", "counter", "t_ms", *(f"adc{j}" for j in range(J)), "pot"]
        df = pd.DataFrame(rows, columns=cols)
        df["received"] = pd.to_datetime(df["received"], unit="s", utc=True)
        df.insert(0, "t", df.pop("t_ms") / 1000.0)
        for j, (name, lk) in enumerate(zip(self.robot.joint_names, self.robot.links)):
            df[f"q_{name}"] = lk.servo.joint_from_adc(df[f"adc{j}"].to_numpy(float))
        df.attrs.update(lost=lost, expected=expected, t_stop=t_stop_ms / 1000.0, rejected=self.stats.rejected_frames + self.stats.bad_lines - rejected0, hz=hz)
        return df


#: alias: ``Link`` and ``Arm`` are the same class
Link = Arm
