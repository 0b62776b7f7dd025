"""Wire layer of the host link (private; the public names are re-exported by :mod:`labkit.arm`).

Everything between :class:`labkit.arm.Arm`'s lab operations and the serial
port, in protocol v3 (``docs/protocol.md``): request lines sealed with
sequence id and CRC-32, the byte stream cut into lines, CRC checks of board
lines, the ``READY`` announcement, event handling, the echo check of
state-changing requests, and the request/retry loop. :class:`Wire` owns one open
port; ``Arm`` creates one and keeps it. What the fields of a reply mean is in
``_replies.py``; feedback frames (``FB``) go to whatever sink is set as
:attr:`Wire.frames` (see ``_feedback.py``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

from labkit.exceptions import DeviceError, ProtocolError
from labkit.arm.bus import BusFault
from labkit.arm._protocol import (
    MAX_JOINTS,
    MAX_LINE,
    NOT_EXECUTED,
    READ_ONLY,
    STALE,
    STRICT_INT,
    CommandRejected,
    check_request,
    echo,
    old_protocol,
    request_body,
    seal,
    unseal,
)
from labkit.arm.link._replies import longest_status

__all__ = ["LinkStats"]

#: largest read of one :meth:`Wire.pump` [bytes] and most reads of one :meth:`Wire._drain`
_READ_CHUNK = 4096
_DRAIN_READS = 16
#: wire time of one byte at 115200 baud, 8N1 [s]
_BYTE_S = 10 / 115200
#: the longest board line [bytes, with CR LF]: a STATUS of the most joints (longer than a request line)
_LONGEST_REPLY = max(MAX_LINE, longest_status(MAX_JOINTS)) + 2
#: how long a reply is still awaited after a damaged line arrived [s]: the wire time of a longest line at 115200 baud
_AFTER_BAD_LINE = _LONGEST_REPLY * _BYTE_S
#: the board's own time to answer an intact request [s] (docs/protocol.md 2.3: 2 ms; a margin for the motion checks),
#: and the commands that may take longer (``SAVE`` writes the EEPROM: up to 0.5 s)
_BOARD_REPLY_S = 0.005
_SLOW_COMMANDS = frozenset({"SAVE"})


class _NoReply(DeviceError):
    """No usable reply to one attempt (raised and caught inside :meth:`Wire.transact`)."""

    def __init__(self, why, executed=None):
        self.why = why
        self.executed = executed  # False: surely not executed; None: unknown
        super().__init__(why)


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
    wrong_echoes: int = 0


@dataclass
class _Line:
    kind: str  # OK, ERR
    seq: int | None
    tokens: list = field(default_factory=list)


class Wire:
    """Byte, line and request layer of one board connection (held by :class:`labkit.arm.Arm`).

    Owns the link state: the open ``port``, its ``name``, reply ``timeout``
    [s], ``retries``, ``stats`` (:class:`LinkStats`), ``events`` (``EV``
    lines received), ``info`` (:class:`BoardInfo` once the owner has shaken
    hands), ``frames`` (sink of ``FB`` lines while a stream is recorded) and
    the line buffers.

    Parameters
    ----------
    port : BoardPort
        An open port to the board (:class:`labkit.arm.BoardPort`).
    name : str
        Port name used in error messages.
    timeout : float
        Reply timeout of one request attempt [s].
    retries : int
        Extra attempts of a request whose reply was lost or garbled.
    """

    def __init__(self, port, *, name, timeout, retries):
        self.port = port
        self.name = name
        self.timeout = float(timeout)
        self.retries = int(retries)
        self.stats = LinkStats()
        self.events = []
        self.info = None
        #: object with ``add(tokens)`` receiving every ``FB`` line, or None (frames are ignored)
        self.frames = None
        #: the fields of the board's ``READY`` line once received since the port was opened
        self.ready = None
        #: ``(protocol, line)`` of the first intact line of an older protocol (1: XOR checksum, 2: CRC-16) received:
        #: an old firmware; ``None`` if none
        self.old_seen = None
        #: ``#seq`` of the last state-changing request known to have run (the board's ``STATUS last=``);
        #: ``None`` until the handshake has read it
        self.last_seq = None
        self._seq = 0
        #: :meth:`clock` when the last complete line was read
        self._line_at = -math.inf
        self._buf = bytearray()
        self._lines = []

    def close(self):
        """Close the port (never raises, even if the port has vanished)."""
        port, self.port = self.port, None
        if port is not None:
            try:
                port.close()
            except Exception:  # noqa: BLE001 - closing a vanished port must not raise
                pass

    # -- time --------------------------------------------------------------------------
    def clock(self):
        """Board time [s] for a simulated board (``sim://``, ``simavr://``), else the wall clock.

        The port (a :class:`labkit.arm.BoardPort`) offers its board's time as ``port.board_time``, or
        ``None`` for a real board. All waits and timeouts of
        the link are in these seconds, so a simulated board running faster or slower
        than real time, or stepped by the host's waits (``clock=lockstep``), keeps
        its timing whatever the host machine does.

        Returns
        -------
        float
            Seconds (board time since power-up, or ``time.monotonic()``).
        """
        port = self.port
        board_time = None if port is None else self.io(lambda: port.board_time)
        return time.monotonic() if board_time is None else board_time

    def _port_seconds(self, seconds):
        """Read timeout for the port that lets ``seconds`` of :meth:`clock` pass.

        A ``realtime`` simulated port waits on the wall clock while board time runs
        ``port.time_scale`` times faster; any other port (a real board, or a
        ``lockstep`` one whose reads wait in board time) takes board seconds.
        """
        port = self.port
        if port is not None and port.clock == "realtime":
            return seconds / port.time_scale
        return seconds

    # -- bytes and lines ---------------------------------------------------------------------
    def io(self, fn, *args):
        """Call a port function, turning a failing or vanished port into :class:`DeviceError`.

        Parameters
        ----------
        fn : callable
            A port method (or a function reading a port property).
        *args
            Its arguments.

        Returns
        -------
        object
            What ``fn`` returned.
        """
        import serial

        if self.port is None:
            raise DeviceError("the link is closed")
        try:
            return fn(*args)
        except BusFault:  # a servo bus stopped the arm: its message names the servo, the fault and the torque-off
            raise
        except (serial.SerialException, OSError) as exc:
            raise DeviceError(f"{self.name}: port vanished or failed: {exc}") from None

    def _send(self, text):
        self.io(self.port.write, text.encode("ascii"))
        self.stats.sent += 1

    def pump(self, timeout):
        """Read for up to ``timeout`` s of :meth:`clock` and handle complete lines (early once one arrived).

        Parameters
        ----------
        timeout : float
            Longest wait [s].

        Returns
        -------
        bool
            Whether at least one line was handled.
        """
        port = self.port
        if port is None:
            raise DeviceError("the link is closed")
        port.timeout = max(self._port_seconds(timeout), 0.0)
        waiting = self.io(lambda: port.in_waiting)
        # at most _READ_CHUNK bytes: a board flooding the line is read in bounded steps between deadline checks
        chunk = self.io(port.read, min(max(1, waiting), _READ_CHUNK))
        if not chunk:
            return False
        self._buf += chunk
        got = False
        while True:
            k = min((i for i in (self._buf.find(b"\n"), self._buf.find(b"\r")) if i >= 0), default=-1)
            if k < 0:
                if len(self._buf) > 4 * MAX_LINE:
                    self._buf.clear()
                    self.stats.bad_lines += 1
                break
            raw = bytes(self._buf[:k])
            del self._buf[:k + 1]
            if raw:
                self._dispatch(raw)
                got = True
        if got:
            self._line_at = self.clock()
        return got

    def _dispatch(self, raw):
        body = unseal(raw)
        if body is None:
            if self.old_seen is None and (old := old_protocol(raw)) is not None:
                self.old_seen = (old, raw.decode("ascii"))
            self.stats.bad_lines += 1
            return
        tokens = body.decode("ascii").split()
        kind = tokens[0] if tokens else ""
        if kind == "FB":
            if self.frames is not None:
                self.frames.add(tokens)
            return
        if kind == "READY":
            if self.ready is not None and self.info is not None:
                self.events.append(("RESET-UNEXPECTED", tokens[1:]))
            self.ready = tokens[1:]
            self.events.append(("READY", tokens[1:]))
            return
        if kind == "EV" and len(tokens) >= 2:
            self.events.append((tokens[1], tokens[2:]))
            return
        if kind in ("OK", "ERR") and len(tokens) >= 2:
            seq = None
            if tokens[1].startswith("#"):
                if not STRICT_INT.match(tokens[1][1:]):
                    self.stats.bad_lines += 1
                    return
                seq = int(tokens[1][1:])
                tokens = [kind] + tokens[2:]
            self._lines.append(_Line(kind, seq, tokens))
            return
        self.stats.bad_lines += 1

    def wait_ready(self, seconds):
        """Handle lines until the board's ``READY`` arrives or ``seconds`` [board time] pass; drop stray ``ERR`` lines.

        Parameters
        ----------
        seconds : float
            Longest wait [s of :meth:`clock`].

        Returns
        -------
        list of str or None
            The fields of the ``READY`` line (``["labkit-arm", "2", "fw=...", ...]``), or ``None``.
        """
        deadline = self.clock() + seconds
        while self.ready is None and self.old_seen is None and self.clock() < deadline:
            self.pump(0.05)
        self._lines = [ln for ln in self._lines if ln.kind != "ERR"]
        return self.ready

    # -- requests ----------------------------------------------------------------------------
    def _next_seq(self):
        self._seq = (self._seq % 65535) + 1
        return self._seq

    def follow(self, seq):
        """Number the next requests after ``seq`` (the board's ``STATUS last=``) and after those already sent.

        Parameters
        ----------
        seq : int
            The last ``#seq`` the board executed (0..65535).
        """
        self._seq = max(self._seq, int(seq) % 65535)

    def reply_wait(self, command, request_bytes):
        """How long one attempt awaits its reply [s of :meth:`clock`]: :attr:`timeout`, shorter in lockstep.

        A lockstep simulated port (``clock == "lockstep"``: ``sim://`` and ``simavr://`` stepped by the host's
        waits) has an exact board clock and no host, USB or scheduling latency, so a reply that has not come
        within the protocol's bound never comes: the request's and a longest reply's wire time at 115200 baud
        plus the board's reply time (docs/protocol.md 2.3). A lost reply then costs that, not the full timeout
        (a reply later than the bound would only cost a resend, which the board answers without running it
        again). Any other port, and ``SAVE``, waits :attr:`timeout`.

        Parameters
        ----------
        command : str
            Upper-case command name.
        request_bytes : int
            Length of the request line as sent [bytes].

        Returns
        -------
        float
            Reply timeout of the attempt [s].
        """
        if not self._wire_timed(command):
            return self.timeout
        return min(self.timeout, (request_bytes + _LONGEST_REPLY) * _BYTE_S + _BOARD_REPLY_S)

    def reply_quiet(self, command, request_bytes):
        """When silence on a lockstep port means no reply is coming [s after sending], or ``None``.

        The request's wire time plus the board's reply time (docs/protocol.md 2.3): by then its reply has
        begun, unless the request was lost or damaged. ``None`` (wait the whole :meth:`reply_wait`) on any
        other port and for ``SAVE``.

        Parameters
        ----------
        command : str
            Upper-case command name.
        request_bytes : int
            Length of the request line as sent [bytes].

        Returns
        -------
        float or None
            Seconds of :meth:`clock`.
        """
        if not self._wire_timed(command):
            return None
        return request_bytes * _BYTE_S + _BOARD_REPLY_S

    def _wire_timed(self, command):
        """Whether the reply to ``command`` is bounded by wire times: a lockstep port, and not ``SAVE``."""
        return command not in _SLOW_COMMANDS and self.port is not None and self.port.clock == "lockstep"

    def _await(self, seq, timeout=None, quiet=None):
        """The reply to ``seq`` within ``timeout`` [s]; on a lockstep port give up once the line stays ``quiet``.

        ``quiet`` [s after the call]: when the reply has not begun by then (no byte of a line arriving, and
        none within the board's reply time after the last line), no reply is coming: a lockstep board's clock
        is exact, so it can tell, and the request is resent at once instead of after the timeout.
        """
        timeout = self.timeout if timeout is None else timeout
        start = self.clock()
        deadline = start + timeout
        silent = None if quiet is None else start + quiet
        bad = self.stats.bad_lines
        while True:
            if self.stats.bad_lines > bad:
                # a damaged line came, most likely the reply (the board sends exactly one per request): wait
                # only as long as a reply behind it would need, then resend (a resent request never runs twice)
                bad = self.stats.bad_lines
                deadline = min(deadline, self.clock() + _AFTER_BAD_LINE)
            for k, ln in enumerate(self._lines):
                if ln.seq == seq or (ln.kind == "ERR" and ln.seq is None):
                    del self._lines[k]
                    if ln.seq is None:
                        code = int(ln.tokens[1]) if ln.tokens[1:2] and ln.tokens[1].isdigit() else 0
                        raise _NoReply(f"board reported a garbled request (ERR {code})",
                                       executed=False if code in NOT_EXECUTED else None)
                    return ln
            self._lines.clear()  # stale replies to earlier attempts
            now = self.clock()
            left = deadline - now
            if left <= 0:
                self.stats.timeouts += 1
                raise _NoReply(f"no valid reply within {timeout:g} s")
            if silent is not None:
                # a line in progress, or one that may follow the last within the board's reply time: wait for it
                quiet_at = max(silent, self._line_at + _BOARD_REPLY_S)
                if now >= quiet_at and not self._buf.strip(b"\r\n") and not self.io(lambda: self.port.in_waiting):
                    self.stats.timeouts += 1
                    raise _NoReply(f"no valid reply: none began within {quiet_at - start:.3g} s (lockstep board clock)")
                if now < quiet_at:
                    left = min(left, quiet_at - now)
            self.pump(left)

    def _drain(self):
        """Handle the lines already received; forget unanswered replies (stale by now).

        Bounded: at most ``_DRAIN_READS`` reads, so a board that never stops sending (a flood
        of bytes faster than they are read) cannot hold the host here; what is left is read by
        the next wait, which has a deadline.
        """
        for _ in range(_DRAIN_READS):
            if not self.io(lambda: self.port.in_waiting):
                break
            self.pump(0.0)
        self._lines.clear()

    def hold(self, why):
        """Stop the arm (``STOP``) after something went wrong, then raise :class:`DeviceError` saying ``why``.

        Parameters
        ----------
        why : str
            What went wrong (names the command).

        Raises
        ------
        DeviceError
            Always; the message says whether the arm is now stopped.
        """
        try:
            self.transact("STOP", retries=max(self.retries, 3), stop_on_wrong_echo=False, renumber_stale=True)
            state = "the arm is stopped (STOP sent)"
        except DeviceError as exc:
            state = f"STOP failed too ({exc}): switch the arm off"
        raise DeviceError(f"{self.name}: {why}; {state}")

    def check_last(self, last, pending=None):
        """Compare the board's ``STATUS last=`` with the state-changing requests the host knows ran.

        Parameters
        ----------
        last : int
            ``#seq`` of the last state-changing request the board executed.
        pending : int, optional
            ``#seq`` of a request whose reply was lost (it may have run).

        Returns
        -------
        bool
            Whether ``pending`` ran.

        Raises
        ------
        DeviceError
            The board executed a request the host did not send (the arm is stopped first).
        """
        if pending is not None and last == pending:
            self.last_seq = last
            return True
        if last != self.last_seq:
            self.hold(f"the board executed request #{last}, which the host never had acknowledged "
                      f"(last known #{self.last_seq}): unrequested motion")
        return False

    def transact(self, command, *args, motion=False, verify=None, parse=None, retries=None, stop_on_wrong_echo=True,
                 renumber_stale=False):
        """Send one request until it is acknowledged; return the (parsed) reply.

        Every request is sealed (``#seq`` and CRC-32). The ``OK`` reply to a
        state-changing request must echo the CRC of exactly what was sent
        (``p=HHHHHHHH``); a different echo means the board ran something else: the
        arm is stopped and :class:`DeviceError` raised.

        Parameters
        ----------
        command : str
            Upper-case command name.
        *args : int
            Integer arguments.
        motion : bool
            A motion request: after a lost reply, ``verify(seq)`` tells whether it ran
            (it is never blindly repeated).
        verify : callable, optional
            ``verify(seq) -> bool`` for motion requests.
        parse : callable, optional
            ``parse(fields)`` of the ``OK`` reply's fields after the command name (and echo).
        retries : int, optional
            Extra attempts; default :attr:`retries`.
        stop_on_wrong_echo : bool
            Send ``STOP`` (through :meth:`hold`) before raising on a wrong echo; off for that
            ``STOP`` itself.
        renumber_stale : bool
            On ``ERR 12 STALE`` (not executed) number the request after the board's newest ``#seq`` and send it
            again instead of raising; for the ``STOP`` of :meth:`hold`, which must get through.

        Returns
        -------
        object
            ``parse(fields)``, or without ``parse`` the reply line (``tokens``:
            ``["OK", command, fields...]``, echo removed).

        Raises
        ------
        OptionError
            The sealed line would be longer than the protocol's ``MAX_LINE`` (the board would discard it): nothing
            is sent (:func:`labkit.arm._protocol.check_request`).
        CommandRejected
            The board answered ``ERR`` for a request that arrived intact.
        DeviceError
            No valid reply after all attempts, a wrong echo, or the board reset itself.
        """
        if any(k == "RESET-UNEXPECTED" for k, _ in self.events):
            raise DeviceError(f"{self.name}: the board reset itself (READY); its state is lost - reconnect")
        args = [int(a) for a in args]
        state_changing = command not in READ_ONLY
        expected_echo = echo(command, args) if state_changing else None
        last = None
        retries = self.retries if retries is None else retries
        # every attempt carries the same #seq: a board that ran it answers a resent copy with its reply and does
        # not run it again (docs/protocol.md 2.1, firmware 2.2.0 on), so a lost reply costs a resend, never a replay;
        # an old copy arriving after newer requests is refused as stale (ERR 12, firmware 2.3.0)
        # a line longer than the board's limit would be discarded as garbled (ERR 4) however often it is sent:
        # refused here, before anything is sent or numbered
        check_request(command, args, seq=(self._seq % 65535) + 1)
        seq = self._next_seq()
        body = request_body(seq, command, args)
        for attempt in range(retries + 1):
            self._drain()
            line = ("\n" if attempt else "") + seal(body) + "\n"
            self._send(line)
            try:
                reply = self._await(seq, self.reply_wait(command, len(line)), self.reply_quiet(command, len(line)))
            except _NoReply as exc:
                last = exc
                self.stats.retries += attempt < retries
                if motion:  # the reply may be lost after the request ran: ask the board
                    if verify(seq):
                        self.stats.verified += 1
                        return _Line("OK", seq, ["OK", command])
                continue
            self.stats.replies += 1
            if reply.kind == "OK":
                if reply.tokens[1:2] != [command]:
                    last = _NoReply(f"reply names {reply.tokens[1:2]}, expected {command}")
                    continue
                if state_changing:
                    got = reply.tokens[2] if len(reply.tokens) > 2 else None
                    if got != expected_echo:
                        self.stats.wrong_echoes += 1
                        if stop_on_wrong_echo:
                            self.hold(f"{command} {' '.join(map(str, args))} (#{seq}) was answered with echo "
                                      f"{got}, expected {expected_echo}: the board ran something else")
                        raise DeviceError(f"{self.name}: {command} #{seq}: wrong echo {got}")
                    del reply.tokens[2]
                    if self.last_seq is not None:
                        self.last_seq = seq
                if parse is None:
                    return reply
                try:
                    return parse(reply.tokens[2:])
                except (ProtocolError, ValueError, KeyError, IndexError) as exc:
                    self.stats.bad_lines += 1
                    last = _NoReply(f"malformed {command} reply {' '.join(reply.tokens)!r} ({exc})")
                    if motion:
                        return reply  # acknowledged; only the extra fields are unusable
                    continue
            code = int(reply.tokens[1]) if len(reply.tokens) > 1 and reply.tokens[1].isdigit() else 0
            if code in NOT_EXECUTED:
                # labkit never sends bad syntax: the line was damaged on the way (e.g. the "*" of a read-only
                # request, which the board may then take as typed by a person); it did not run: send it again
                last = _NoReply(" ".join(reply.tokens))
                continue
            name = reply.tokens[2] if len(reply.tokens) > 2 else "?"
            newest = reply.tokens[-1]
            if code == STALE and renumber_stale and newest[:1] == "#" and newest[1:].isdigit():
                self.follow(int(newest[1:]))  # "ERR 12 STALE after #<newest>": it did not run
                check_request(command, args, seq=(self._seq % 65535) + 1)
                seq = self._next_seq()
                body = request_body(seq, command, args)
                last = _NoReply(" ".join(reply.tokens))
                continue
            if code == STALE:
                # not run, and never resent under this seq (it would stay stale): the board accepted newer requests
                # than this one since the handshake, which only another program on the port can have sent
                raise CommandRejected(f"{self.name}: {command} #{seq} was not executed: the board has run newer "
                                      f"requests ({' '.join(reply.tokens[1:])}) than labkit sent; is another "
                                      f"program talking to the board? Reconnect (a new Arm) to start a new session",
                                      code, name)
            raise CommandRejected(f"{self.name}: {command} rejected: {' '.join(reply.tokens[1:])}", code, name)
        raise DeviceError(f"{self.name}: {command} failed after {retries + 1} attempts: {last}")
