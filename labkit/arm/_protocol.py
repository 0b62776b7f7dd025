"""Protocol v3 definitions shared by both ends of the wire (``docs/protocol.md``).

The host link (:class:`labkit.arm.Arm` and its wire layer) and the virtual
board (:class:`labkit.arm.VirtualBoard`) both take from here what the
protocol fixes: the protocol version, the line length limit, the error codes,
the CRC-32 line checksum (CRC-32/ISO-HDLC, ``zlib.crc32``) and how a line is sealed with it, which
commands may go unsealed, the echo of a parsed request, the strict integer
syntax of board lines, the angle unit (centidegrees), and
:class:`CommandRejected`, the error of an ``ERR`` reply. Nothing here knows
about ports, clocks or physics.

Examples
--------
>>> seal("#7 MOVE 4500 9000 3000 ")
'#7 MOVE 4500 9000 3000 *C63C85AC'
>>> unseal(b"OK #7 PING 200*B63589B2")
b'OK #7 PING 200'
>>> unseal(b"OK #7 PING 201*B63589B2") is None  # checksum mismatch
True
>>> echo("MOVE", [4500, 9000, 3000])
'p=53C7C857'
>>> ERRORS[11]
'SPEED'
"""

from __future__ import annotations

import binascii
import math
import re
import zlib

from labkit.exceptions import CommandRejected, ProtocolError, RobotError

__all__ = ["checksum", "CommandRejected", "PROTOCOL_VERSION", "MAX_LINE", "ERRORS", "READ_ONLY"]

#: protocol version spoken by both ends (``HELLO`` ``proto=``, ``READY labkit-arm <version>``); 3: CRC-32
PROTOCOL_VERSION = 3
#: longest line [bytes] before the end of line, either direction (``HELLO`` ``maxline=``; protocol 2's 160 plus
#: the four more digits of the CRC-32)
MAX_LINE = 164
#: error codes of ``ERR <code> <NAME>`` replies (``docs/protocol.md`` section 5)
ERRORS = {1: "BADCHK", 2: "SYNTAX", 3: "UNKNOWN", 4: "TOOLONG", 5: "RANGE", 6: "LIMIT", 7: "QFULL",
          8: "BUSY", 9: "DISCONT", 10: "EEPROM", 11: "SPEED", 12: "STALE"}
#: factory speed limit of every joint [cdeg/s] (600 deg/s, above any hobby servo); acceleration unchecked
VMAX_FACTORY = 60000
#: largest speed [cdeg/s] and acceleration [cdeg/s^2] limits ``LIMITS`` accepts
VMAX_MAX = 1_000_000
AMAX_MAX = 100_000_000
#: the fields of a calibration row (``CAL``, the EEPROM image's int16/int8 fields) and the values the board
#: accepts in each: name, lowest, highest, unit (pulses within an RC servo's 400-2600 us, angles within int16)
CAL_FIELDS = (("pmin", 400, 2600, "us"), ("pmax", 400, 2600, "us"), ("zero", -32000, 32000, "cdeg"),
              ("direction", -1, 1, ""), ("lo", -32000, 32000, "cdeg"), ("hi", -32000, 32000, "cdeg"))
#: commands a person may type without ``#seq`` and ``*CRC`` (they change nothing); all others must be sealed
READ_ONLY = frozenset({"HELLO", "PING", "STATUS", "READ"})
#: codes of a request that never ran (damaged on the way: checksum, syntax, unknown, too long)
NOT_EXECUTED = frozenset({1, 2, 3, 4})
#: code of a sealed request refused as stale (its seq is not newer than the newest accepted one): not run, and
#: not to be resent under that seq (docs/protocol.md 2.1)
STALE = 12

#: a board line without its CR LF: printable body, ``*``, eight upper-case hex digits (CRC-32)
BOARD_LINE = re.compile(rb"^([\x20-\x7e]*)\*([0-9A-F]{8})$")
#: a protocol-1 (XOR checksum, two hex digits) or protocol-2 (CRC-16, four) board line: recognised only to refuse
#: an old board
OLD_LINE = re.compile(rb"^([\x20-\x7e]*)\*([0-9A-F]{2}|[0-9A-F]{4})$")
#: an integer as the board writes it (never ``+``, leading zeros or ``-0``)
STRICT_INT = re.compile(r"^(0|-?[1-9][0-9]{0,9})$")
#: an integer argument of a request (optional sign, 1 to 10 digits)
REQUEST_INT = re.compile(r"^[+-]?[0-9]{1,10}$")
#: the optional sequence id token of a request
REQUEST_SEQ = re.compile(r"^#([0-9]{1,5})$")
#: what may follow the last ``*`` of a request: eight hex digits (either case), then blanks
REQUEST_CHECKSUM = re.compile(r"^[0-9A-Fa-f]{8}[ \t]*$")


def checksum(text):
    """CRC-32 of the bytes of ``text``, the protocol's line checksum (int 0..2**32 - 1).

    The CRC-32/ISO-HDLC of zlib, Ethernet and PNG (polynomial 0x04C11DB7 reflected, initial value and final XOR
    0xFFFFFFFF; check value ``CBF43926`` for ``"123456789"``). It also seals the board's EEPROM image.

    Parameters
    ----------
    text : str or bytes-like
        Line body (ASCII), without the ``*HHHHHHHH`` suffix.

    Returns
    -------
    int
        Checksum, 0..4294967295 (sent as eight hex digits).

    Raises
    ------
    UnicodeEncodeError
        ``text`` is a str with non-ASCII characters.

    Examples
    --------
    >>> f"{checksum('123456789'):08X}"
    'CBF43926'
    >>> f"{checksum('#7 PING'):08X}"
    '8983EB3B'
    """
    return zlib.crc32(text.encode("ascii") if isinstance(text, str) else bytes(text))


def seal(body):
    """``body`` with its checksum appended, ``"<body>*HHHHHHHH"`` (no end of line).

    Parameters
    ----------
    body : str
        Line body (ASCII).

    Returns
    -------
    str
    """
    return f"{body}*{checksum(body):08X}"


def unseal(raw):
    """Body of a board line (bytes, without CR LF) whose checksum matches, else ``None``.

    Parameters
    ----------
    raw : bytes
        One line as received, end of line removed.

    Returns
    -------
    bytes or None
        The body before ``*HHHHHHHH``; ``None`` for a malformed line or a checksum mismatch.
    """
    m = BOARD_LINE.match(raw)
    if not m or int(m.group(2), 16) != checksum(m.group(1)):
        return None
    return m.group(1)


def old_protocol(raw):
    """The protocol of an intact board line of an older firmware (``raw``: bytes, no CR LF), else ``None``.

    Protocol 1 sealed lines with an XOR checksum (``*HH``), protocol 2 with a CRC-16/CCITT-FALSE (``*HHHH``).

    Parameters
    ----------
    raw : bytes
        One line as received, end of line removed.

    Returns
    -------
    int or None
        1 or 2, or ``None`` for anything else (a protocol-3 line, damage).

    Examples
    --------
    >>> old_protocol(b"OK #7 PING 200*232C"), old_protocol(b"OK #7 PING 200*B63589B2")
    (2, None)
    """
    m = OLD_LINE.match(raw)
    if not m:
        return None
    body, value = m.group(1), int(m.group(2), 16)
    if len(m.group(2)) == 4:
        return 2 if binascii.crc_hqx(body, 0xFFFF) == value else None
    x = 0
    for b in body:
        x ^= b
    return 1 if x == value else None


def echo(command, args):
    """The ``p=HHHHHHHH`` field a board puts in the ``OK`` reply to a sealed request: CRC of what it parsed.

    Parameters
    ----------
    command : str
        Command name (any case; the echo uses upper case).
    args : sequence of int
        The integer arguments as parsed.

    Returns
    -------
    str
        ``"p=HHHHHHHH"``, the CRC-32 of ``"NAME a0 a1 ..."`` (integers written plainly).
    """
    return f"p={checksum(' '.join([command.upper(), *(str(int(a)) for a in args)])):08X}"


def board_int(text):
    """Parse an integer field exactly as the board writes it.

    Parameters
    ----------
    text : str

    Returns
    -------
    int

    Raises
    ------
    ProtocolError
        ``text`` is not written the board's way (sign, leading zeros, not digits).
    """
    if not STRICT_INT.match(text):
        raise ProtocolError(f"expected a board integer (digits, no '+' or leading zeros), got {text!r}")
    return int(text)


def cdeg(q):
    """Joint value [rad] -> integer centidegrees, the protocol's angle unit.

    Parameters
    ----------
    q : float
        Joint value [rad].

    Returns
    -------
    int
    """
    return int(round(math.degrees(float(q)) * 100))


def wire_speed_limits(robot):
    """The robot file's joint speed and acceleration limits in the board's units (``LIMITS``).

    Parameters
    ----------
    robot : labkit.Robot
        ``max_velocity`` [rad/s] and ``max_acceleration`` [rad/s^2] of each joint (``None``: none).

    Returns
    -------
    vmax, amax : list of int
        [cdeg/s], [cdeg/s^2], rounded down; 0 where the robot file gives no limit (unchecked).
    """
    def wire(value, largest):
        return 0 if value is None else min(int(math.floor(math.degrees(value) * 100)), largest)

    return ([wire(lk.max_velocity, VMAX_MAX) for lk in robot.links],
            [wire(lk.max_acceleration, AMAX_MAX) for lk in robot.links])


def check_calibration_row(row, where):
    """Refuse a calibration row whose values the board cannot store (before anything is sent).

    Parameters
    ----------
    row : sequence of int
        ``[pmin, pmax, zero, direction, lo, hi]`` (:data:`CAL_FIELDS`).
    where : str
        What the row belongs to, for the message (``"scara: joint 'quill'"``).

    Raises
    ------
    RobotError
        A field outside what the board accepts (an int16 pulse width of 35407 us, limits past
        +-320 deg): names ``where``, the field, the value and the accepted range.

    Examples
    --------
    >>> check_calibration_row([500, 2500, 0, 1, 0, 18000], "joint 'base'")
    >>> check_calibration_row([1000, 35407, 0, 1, 0, 573], "joint 'quill'")
    Traceback (most recent call last):
    ...
    labkit.exceptions.RobotError: joint 'quill': calibration field pmax = 35407 us does not fit the board's protocol (expected 400..2600 us): a servo's pulse range must span its 180 deg (prismatic: pi m) travel
    """
    for (name, low, high, unit), value in zip(CAL_FIELDS, row):
        if not low <= value <= high or (name == "direction" and value == 0):
            unit = f" {unit}" if unit else ""
            raise RobotError(f"{where}: calibration field {name} = {value}{unit} does not fit the board's protocol "
                             f"(expected {low}..{high}{unit}): a servo's pulse range must span its 180 deg "
                             f"(prismatic: pi m) travel" if name in ("pmin", "pmax") else
                             f"{where}: calibration field {name} = {value}{unit} does not fit the board's protocol "
                             f"(expected {low}..{high}{unit})", f"servo.{name}")


def wire_calibrations(robot):
    """The robot file's servo calibrations in the board's units (the rows ``CAL`` sends).

    A row is ``[pmin, pmax, zero, direction, lo, hi]``: the pulse widths at servo angles 0 and
    180 deg [us], the servo angle at ``q = 0`` and the joint limits [cdeg] (prismatic joints in
    metres read as radians, as on the wire).

    Parameters
    ----------
    robot : labkit.Robot

    Returns
    -------
    joints : list of (list of int or None)
        One row per joint; None for a joint without a servo calibration.
    gripper : list of int or None
        The gripper channel's row (its pulse range), None without a hobby-servo gripper (a bus gripper has no
        pulse range).

    Raises
    ------
    RobotError
        A joint's row does not fit the protocol's fields (:func:`check_calibration_row`): nothing is sent.
    """
    joints = []
    for j, lk in enumerate(robot.links):
        cal = lk.servo
        if cal is None:
            joints.append(None)
            continue
        lo_a, hi_a = cal.angle_range
        p0, p1 = cal.pulse_range
        pmin = int(round(p0 + (0.0 - lo_a) / (hi_a - lo_a) * (p1 - p0)))
        pmax = int(round(p0 + (math.pi - lo_a) / (hi_a - lo_a) * (p1 - p0)))
        row = [pmin, pmax, cdeg(cal.zero), int(cal.direction), *(cdeg(v) for v in lk.limits)]
        check_calibration_row(row, f"{robot.name}: joint {robot.joint_names[j]!r}")
        joints.append(row)
    g = robot.gripper
    gripper = None if not hasattr(g, "open_us") else [int(round(min(g.open_us, g.closed_us))), int(round(max(g.open_us, g.closed_us))),
                                      0, 1, 0, 18000]
    return joints, gripper
