"""The board's replies in SI units (private; the public names are re-exported by :mod:`labkit.arm`).

The fields after ``OK [#seq] <COMMAND>`` of ``HELLO``, ``PING``, ``STATUS``,
``READ`` and ``STOP`` (``docs/protocol.md`` section 4) as Python values. A
field that passed the CRC but is still malformed (a board bug, not line noise)
raises :class:`~labkit.exceptions.ProtocolError`; the wire layer counts it as
a bad line and asks again.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from labkit.exceptions import ProtocolError
from labkit.arm._protocol import CAL_FIELDS, POSITION_WIDEST, SEQ_MAX, board_int, seal

__all__ = ["BoardInfo", "Status"]

#: the widest value of each ``STATUS`` field after ``q`` (docs/protocol.md 4.1 and 4.4-4.6): the widest gripper
#: pulse (``CAL`` ``pmax``), a queue of at most 9 segments, ``done`` and ``t`` as uint32, ``timeout`` 60000 ms,
#: ``stream`` 200 Hz, two hex digits of flags, ``mem`` as uint16 and the widest ``last``
_STATUS_WIDEST_TAIL = (f"grip={CAL_FIELDS[1][2]} queue=9 free=0 done={2 ** 32 - 1} timeout=60000 stream=200 flags=FF "
                       f"mem=65535 t={2 ** 32 - 1} last={SEQ_MAX}")


def longest_status(joints):
    """Length [bytes] of the longest ``STATUS`` reply of a board of ``joints`` joints, without its end of line.

    Every field at its widest, every joint at the widest position (``-32000``): ``147 + 7 J`` bytes, longer
    than a request line (``MAX_LINE``) from 3 joints on. ``STATUS`` is the only board line that can be
    (``docs/protocol.md`` 2.2); the host reads lines of any length up to four times ``MAX_LINE``.

    Parameters
    ----------
    joints : int

    Returns
    -------
    int

    Examples
    --------
    >>> longest_status(3), longest_status(8)
    (168, 203)
    """
    q = ",".join([str(POSITION_WIDEST)] * joints)
    return len(seal(f"OK #{SEQ_MAX} STATUS state=HOLD q={q} {_STATUS_WIDEST_TAIL}"))


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
    """``STATUS`` answer in SI units (``q`` [rad], ``t`` [s], ``timeout`` [s]).

    ``last`` is the ``#seq`` of the last state-changing request the board executed.
    """

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
    last: int = 0


def parse_hello(fields):
    """``HELLO`` reply fields -> :class:`BoardInfo` (the joined text if it is not a labkit arm).

    Parameters
    ----------
    fields : list of str
        Reply tokens after ``OK [#seq] HELLO``.

    Returns
    -------
    BoardInfo or str
    """
    kv = dict(tok.split("=", 1) for tok in fields[1:] if "=" in tok)
    if fields[:1] != ["labkit-arm"]:
        return " ".join(fields)
    return BoardInfo(kv["fw"], board_int(kv["proto"]), board_int(kv["joints"]), board_int(kv["channels"]),
                     board_int(kv["queue"]), board_int(kv["maxline"]))


def parse_ping(fields):
    """``PING`` reply fields -> board time [s].

    Parameters
    ----------
    fields : list of str
        Reply tokens after ``OK [#seq] PING``.

    Returns
    -------
    float
    """
    if len(fields) != 1:
        raise ProtocolError(f"expected one field (board time in ms), got {fields!r}")
    return board_int(fields[0]) / 1000.0


def parse_read(fields, n):
    """``READ`` reply fields -> ADC counts of ``n`` joints and the user pot.

    Parameters
    ----------
    fields : list of str
        Reply tokens after ``OK [#seq] READ``.
    n : int
        Joint count.

    Returns
    -------
    ndarray of int, shape (n + 1,)
    """
    vals = [board_int(v) for v in fields]
    if len(vals) != n + 1 or not all(0 <= v <= 1023 for v in vals):
        raise ProtocolError(f"expected {n + 1} counts 0..1023, got {fields!r}")
    return np.array(vals)


def _joints(values, units):
    """Board positions -> joint values [rad | m] through ``units`` (a WireUnits; None: centidegrees)."""
    return np.radians(np.array(values) / 100.0) if units is None else units.joints(values)


def parse_stop(fields, n, units=None):
    """``STOP`` reply fields -> the held joint values [rad | m] (sent in wire units).

    Parameters
    ----------
    fields : list of str
        Reply tokens after ``OK [#seq] STOP``.
    n : int
        Joint count.
    units : WireUnits, optional
        The robot's wire units (``labkit.arm``'s protocol module); default centidegrees for every joint.

    Returns
    -------
    ndarray, shape (n,)
    """
    if len(fields) != n:
        raise ProtocolError(f"expected {n} joint values, got {fields!r}")
    return _joints([board_int(v) for v in fields], units)


def parse_status(fields, n, queue_depth=None, units=None):
    """``STATUS`` reply fields -> :class:`Status`.

    Parameters
    ----------
    fields : list of str
        Reply tokens after ``OK [#seq] STATUS`` (``key=value``).
    n : int
        Joint count.
    queue_depth : int, optional
        The board's queue depth (``HELLO``); ``queue + free`` must equal it.
    units : WireUnits, optional
        The robot's wire units; default centidegrees for every joint.

    Returns
    -------
    Status
    """
    kv = dict(tok.split("=", 1) for tok in fields)
    q = [board_int(v) for v in kv["q"].split(",")]
    if len(q) != n or kv["state"] not in ("IDLE", "RUN", "HOLD"):
        raise ProtocolError(f"expected {n} joint values and state IDLE, RUN or HOLD, "
                            f"got q={kv['q']} state={kv['state']}")
    if not re.fullmatch(r"[0-9A-Fa-f]{1,8}", kv["flags"]):
        raise ProtocolError(f"expected flags as 1 to 8 hex digits, got {kv['flags']!r}")
    st = Status(kv["state"], _joints(q, units), board_int(kv["grip"]), board_int(kv["queue"]),
                board_int(kv["free"]), board_int(kv["done"]), board_int(kv["timeout"]) / 1000.0,
                board_int(kv["stream"]), int(kv["flags"], 16), board_int(kv["mem"]), board_int(kv["t"]) / 1000.0,
                board_int(kv["last"]))
    if queue_depth is not None and st.queue + st.free != queue_depth:
        raise ProtocolError(f"expected queue + free = {queue_depth} (queue depth), got {st.queue} + {st.free}")
    return st
