"""Protocol v3 definitions shared by both ends of the wire (``docs/protocol.md``).

The host link (:class:`labkit.arm.Arm` and its wire layer) and the virtual
board (:class:`labkit.arm.VirtualBoard`) both take from here what the
protocol fixes: the protocol version, the line length limit, the error codes,
the CRC-32 line checksum (CRC-32/ISO-HDLC, ``zlib.crc32``) and how a line is sealed with it, which
commands may go unsealed, the echo of a parsed request, the strict integer
syntax of board lines, the joint positions' units on the wire (:class:`WireUnits`: centidegrees, or
1/18000 of an RC linear servo's stroke), and
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

import numpy as np

from labkit.exceptions import CommandRejected, OptionError, ProtocolError, RobotError
from labkit.robot import JointType, servo_travel

__all__ = ["checksum", "CommandRejected", "PROTOCOL_VERSION", "MAX_LINE", "MAX_JOINTS", "ERRORS", "READ_ONLY",
           "WireUnits", "max_joints", "check_joint_count"]

#: protocol version spoken by both ends (``HELLO`` ``proto=``, ``READY labkit-arm <version>``); 3: CRC-32
PROTOCOL_VERSION = 3
#: longest line [bytes] before the end of line, either direction (``HELLO`` ``maxline=``; protocol 2's 160 plus
#: the four more digits of the CRC-32)
MAX_LINE = 164
#: error codes of ``ERR <code> <NAME>`` replies (``docs/protocol.md`` section 5)
ERRORS = {1: "BADCHK", 2: "SYNTAX", 3: "UNKNOWN", 4: "TOOLONG", 5: "RANGE", 6: "LIMIT", 7: "QFULL",
          8: "BUSY", 9: "DISCONT", 10: "EEPROM", 11: "SPEED", 12: "STALE"}
#: a servo's travel on the wire [wire units]: a hobby servo's 180 deg in centidegrees, an RC linear servo's stroke
SERVO_FULL = 18000
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

#: the widest sequence id a request carries (``#65535``), duration (``MOVE``, ``SEG``: 60000 ms) and joint position
#: (a calibration's ``lo``/``hi``: -32000) as the protocol writes them
SEQ_MAX = 65535
DURATION_MAX_MS = 60000
POSITION_WIDEST = -32000

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


def request_body(seq, command, args):
    """The text of a sealed request before its checksum: ``"#<seq> NAME a0 a1 ... "`` (trailing space).

    Parameters
    ----------
    seq : int
        Sequence id, 1..65535.
    command : str
        Upper-case command name.
    args : sequence of int

    Returns
    -------
    str
        :func:`seal` of it is the line labkit sends (without the end of line).
    """
    return " ".join([f"#{seq}", command, *(str(int(a)) for a in args)]) + " "


def request_length(command, args, seq=SEQ_MAX):
    """Length [bytes] of the sealed request line ``command args`` (without the end of line; ``docs/protocol.md`` 2.1).

    Parameters
    ----------
    command : str
    args : sequence of int
    seq : int
        Its sequence id; default the widest, ``#65535``.

    Returns
    -------
    int

    Examples
    --------
    >>> request_length("PING", [], seq=7), len("#7 PING *8983EB3B")
    (17, 17)
    """
    return len(request_body(seq, command, args)) + 9  # "*HHHHHHHH"


def _widest_args(command, joints, order=3):
    """The arguments of ``command`` for ``joints`` joints held still at the widest position (section 4)."""
    if command == "MOVE":
        return [POSITION_WIDEST] * joints + [DURATION_MAX_MS]
    if command == "SEG":
        return [DURATION_MAX_MS, order] + ([POSITION_WIDEST] + [0] * order) * joints
    raise OptionError(f"expected MOVE or SEG, got {command!r}")


def max_joints(command="SEG", order=5):
    """The most joints whose request ``command`` fits in :data:`MAX_LINE` when they hold still at the widest position.

    A ``MOVE`` carries one position per joint, a ``SEG`` of order ``k`` ``k + 1`` coefficients per joint
    (``docs/protocol.md`` 4.3). Every joint's position is at least as wide as the widest a calibration allows
    (``-32000``, 6 characters) and every other coefficient at least one character (``0``, a joint at rest), with
    the widest ``#seq`` (``#65535``) and duration (``60000``): more joints than this never fit in one line. A
    moving joint's coefficients are wider, so a ``SEG`` may need fewer joints (or shorter segments: the
    coefficients but the first scale with the segment's duration).

    Parameters
    ----------
    command : {"SEG", "MOVE"}
    order : {3, 5}
        The ``SEG`` polynomial order (ignored for ``MOVE``).

    Returns
    -------
    int

    Examples
    --------
    >>> max_joints("SEG", 5), max_joints("SEG", 3), max_joints("MOVE")
    (8, 10, 19)
    """
    joints = 0
    while request_length(command, _widest_args(command, joints + 1, order)) <= MAX_LINE:
        joints += 1
    return joints


#: the most joints the board protocol carries: the widest request per joint, a quintic ``SEG`` (six coefficients
#: a joint), held still at the widest position, fits :data:`MAX_LINE` for this many joints (:func:`max_joints`)
MAX_JOINTS = min(max_joints("MOVE"), max_joints("SEG", 3), max_joints("SEG", 5))


def check_joint_count(robot):
    """Refuse a robot with more joints than the board protocol carries (:data:`MAX_JOINTS`).

    Parameters
    ----------
    robot : labkit.robot.Robot

    Raises
    ------
    RobotError
        ``robot.n > MAX_JOINTS``: names the robot, its joints and the limit (nothing is opened or sent).
    """
    if robot.n > MAX_JOINTS:
        where = f"{robot.name} ({robot.path})" if getattr(robot, "path", None) else robot.name
        raise RobotError(
            f"{where}: {robot.n} joints, but the arm board protocol carries at most {MAX_JOINTS} "
            f"(a request line is at most {MAX_LINE} bytes; a quintic SEG carries 6 coefficients a joint, "
            f"docs/protocol.md 2.1 and 4.3): such an arm cannot run on a labkit board (sim://, an Arduino, a servo "
            f"bus); use a robot file with at most {MAX_JOINTS} joints")


def check_request(command, args, seq=SEQ_MAX):
    """Refuse a request whose sealed line would be longer than :data:`MAX_LINE` (the board discards it: ``ERR 4``).

    Parameters
    ----------
    command : str
        Upper-case command name.
    args : sequence of int
    seq : int
        The sequence id it would carry (default the widest, so the answer does not depend on it).

    Raises
    ------
    OptionError
        The line is too long: names the command, its number of values, the line length and the limit, and
        what to do. Nothing has been sent.
    """
    length = request_length(command, args, seq)
    if length <= MAX_LINE:
        return
    advice = "send fewer values per request"
    if command == "SEG" and len(args) >= 2 and int(args[1]) in (3, 5) and (len(args) - 2) % (int(args[1]) + 1) == 0:
        order = int(args[1])
        joints = (len(args) - 2) // (order + 1)
        advice = (f"this segment carries {joints} joints of order {order}; a SEG of order {order} fits at most "
                  f"{max_joints('SEG', order)} joints even at rest, fewer while they move: use shorter segments "
                  f"(smaller coefficients: a smaller min_duration), order 3 instead of 5, or fewer joints")
    elif command == "MOVE":
        advice = f"a MOVE carries at most {max_joints('MOVE')} joints: use fewer joints"
    raise OptionError(f"{command} with {len(args)} values would be a {length}-byte request line, longer than the "
                      f"board protocol's limit of {MAX_LINE} bytes (docs/protocol.md 2.1; the board would discard it "
                      f"as garbled, ERR 4): nothing was sent - {advice}")


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


class WireUnits:
    """The units of a robot's joint positions on the wire (``docs/protocol.md`` section 3), joint by joint.

    The board counts every joint in integer units of which its servo's travel is 18000
    (:data:`SERVO_FULL`): a hobby servo's 180 deg are 18000 **centidegrees**; an RC linear servo's stroke
    (its servo table's ``range``, :func:`labkit.robot.servo_travel`) is 18000 units of ``stroke / 18000``
    (2.8 um for a 50 mm stroke, 7.8 um for 140 mm). Revolute joints, and prismatic joints without a
    servo (ideal actuators, their metres read as radians), are in centidegrees. So the firmware converts
    every joint with the same integers, and a robot without an RC linear servo is on the wire as before.

    Parameters
    ----------
    robot : labkit.robot.Robot

    Attributes
    ----------
    metres : tuple of float or None
        Per joint: one wire unit [m] of an RC linear servo, None for centidegrees.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> units = WireUnits(Robot.load("arduino_arm_3dof"))
    >>> units.positions([0.5, 1.0, 0.25])
    [2865, 5730, 1432]
    """

    def __init__(self, robot):
        self.metres = tuple(None if lk.servo is None or lk.joint_type is JointType.REVOLUTE
                            else (servo_travel(lk)[1] - servo_travel(lk)[0]) / SERVO_FULL for lk in robot.links)

    def value(self, j, x):
        """Joint ``j``'s value ``x`` [rad | m] (or a rate of it [/s, /s^2]) in wire units, not rounded.

        Parameters
        ----------
        j : int
        x : float

        Returns
        -------
        float
        """
        unit = self.metres[j]
        return math.degrees(float(x)) * 100 if unit is None else float(x) / unit

    def positions(self, q):
        """Joint values ``q`` [rad | m], shape (n,), as the board's integers (rounded to the nearest unit).

        Parameters
        ----------
        q : array_like, shape (n,)

        Returns
        -------
        list of int
        """
        return [int(round(self.value(j, x))) for j, x in enumerate(q)]

    def joints(self, values):
        """The board's integer positions, shape (..., n), as joint values [rad | m].

        Parameters
        ----------
        values : array_like, shape (..., n)

        Returns
        -------
        ndarray, shape (..., n)
        """
        v = np.asarray(values, dtype=float)
        scale = np.array([math.radians(0.01) if u is None else u for u in self.metres])
        cdeg_joints = np.array([u is None for u in self.metres])
        return np.where(cdeg_joints, np.radians(v / 100.0), v * scale)

    def show(self, j, v):
        """Wire value ``v`` of joint ``j`` as a person reads it (``"45 deg"``, ``"12.5 mm"``).

        Parameters
        ----------
        j : int
        v : float

        Returns
        -------
        str
        """
        unit = self.metres[j]
        return f"{v / 100:g} deg" if unit is None else f"{v * unit * 1000:.3g} mm"


def wire_speed_limits(robot):
    """The robot file's joint speed and acceleration limits in the board's units (``LIMITS``).

    Parameters
    ----------
    robot : labkit.Robot
        ``max_velocity`` [rad/s | m/s] and ``max_acceleration`` [rad/s^2 | m/s^2] of each joint (``None``: none).

    Returns
    -------
    vmax, amax : list of int
        [units/s], [units/s^2] (:class:`WireUnits`: cdeg, or 1/18000 of a linear servo's stroke), rounded down;
        0 where the robot file gives no limit (unchecked).
    """
    units = WireUnits(robot)

    def wire(j, value, largest):
        return 0 if value is None else min(int(math.floor(units.value(j, value))), largest)

    return ([wire(j, lk.max_velocity, VMAX_MAX) for j, lk in enumerate(robot.links)],
            [wire(j, lk.max_acceleration, AMAX_MAX) for j, lk in enumerate(robot.links)])


def check_calibration_row(row, where, position_unit="cdeg"):
    """Refuse a calibration row whose values the board cannot store (before anything is sent).

    Parameters
    ----------
    row : sequence of int
        ``[pmin, pmax, zero, direction, lo, hi]`` (:data:`CAL_FIELDS`).
    where : str
        What the row belongs to, for the message (``"scara: joint 'quill'"``).
    position_unit : str
        The unit of ``zero``, ``lo`` and ``hi`` in the message (:class:`WireUnits`).

    Raises
    ------
    RobotError
        A field outside what the board accepts (a hobby servo whose ``pulse_us`` extended to 0 and 180 deg
        pass 2600 us, limits past +-320 deg, a linear servo's limits past 1.78 strokes): names ``where``,
        the field, the value and the accepted range.

    Examples
    --------
    >>> check_calibration_row([500, 2500, 0, 1, 0, 18000], "joint 'base'")
    >>> check_calibration_row([500, 4500, 0, 1, 0, 18000], "joint 'base'")
    Traceback (most recent call last):
    ...
    labkit.exceptions.RobotError: joint 'base': calibration field pmax = 4500 us does not fit the board's protocol (expected 400..2600 us): the pulse widths at the ends of the servo's travel (a hobby servo: 0 and 180 deg)
    """
    for (name, low, high, unit), value in zip(CAL_FIELDS, row):
        if not low <= value <= high or (name == "direction" and value == 0):
            unit = f" {position_unit if unit == 'cdeg' else unit}" if unit else ""
            why = (": the pulse widths at the ends of the servo's travel (a hobby servo: 0 and 180 deg)"
                   if unit == " us" else "")
            raise RobotError(f"{where}: calibration field {name} = {value}{unit} does not fit the board's protocol "
                             f"(expected {low}..{high}{unit}){why}", f"servo.{name}")


def wire_calibrations(robot):
    """The robot file's servo calibrations in the board's units (the rows ``CAL`` sends).

    A row is ``[pmin, pmax, zero, direction, lo, hi]``: the pulse widths at the ends of the servo's
    travel (:func:`labkit.robot.servo_travel`: a hobby servo's 0 and 180 deg, extended from its
    ``pulse_us`` over ``range``; an RC linear servo's stroke ends, its ``pulse_us``) [us], the servo
    position at ``q = 0`` from the travel's start and the joint limits, in wire units (:class:`WireUnits`).

    Parameters
    ----------
    robot : labkit.robot.Robot

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
    units = WireUnits(robot)
    joints = []
    for j, lk in enumerate(robot.links):
        cal = lk.servo
        if cal is None:
            joints.append(None)
            continue
        start, end = servo_travel(lk)
        row = [int(round(float(cal.pulse_from_servo_angle(a)))) for a in (start, end)]
        row += [int(round(units.value(j, cal.zero - start))), int(cal.direction),
                *(int(round(units.value(j, v))) for v in lk.limits)]
        check_calibration_row(row, f"{robot.name}: joint {robot.joint_names[j]!r}",
                              "cdeg" if units.metres[j] is None else f"units of {units.metres[j] * 1e6:.3g} um")
        joints.append(row)
    g = robot.gripper
    gripper = None if not hasattr(g, "open_us") else [int(round(min(g.open_us, g.closed_us))), int(round(max(g.open_us, g.closed_us))),
                                      0, 1, 0, 18000]
    return joints, gripper
