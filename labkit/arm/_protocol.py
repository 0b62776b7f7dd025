"""Protocol v1 definitions shared by both ends of the wire (``docs/protocol.md``).

The host link (:class:`labkit.arm.Arm` and its wire layer) and the virtual
board (:class:`labkit.arm.VirtualBoard`) both take from here what the
protocol fixes: the protocol version, the line length limit, the error codes,
the XOR line checksum and how a line is sealed with it, the strict integer
syntax of board lines, the angle unit (centidegrees), the CRC-16 of the
EEPROM image, and :class:`CommandRejected`, the error of an ``ERR`` reply.
Nothing here knows about ports, clocks or physics.

Examples
--------
>>> seal("#7 PING")
'#7 PING*24'
>>> unseal(b"OK #7 PING 200*12")
b'OK #7 PING 200'
>>> unseal(b"OK #7 PING 201*12") is None  # checksum mismatch
True
>>> ERRORS[6]
'LIMIT'
"""

from __future__ import annotations

import math
import re

from labkit.exceptions import DeviceError, ProtocolError

__all__ = ["checksum", "CommandRejected", "PROTOCOL_VERSION", "MAX_LINE", "ERRORS"]

#: protocol version spoken by both ends (``HELLO`` ``proto=``, ``EV BOOT`` ``proto=``)
PROTOCOL_VERSION = 1
#: longest line [bytes] before the end of line, either direction (``HELLO`` ``maxline=``)
MAX_LINE = 160
#: error codes of ``ERR <code> <NAME>`` replies (``docs/protocol.md`` section 5)
ERRORS = {1: "BADCHK", 2: "SYNTAX", 3: "UNKNOWN", 4: "TOOLONG", 5: "RANGE", 6: "LIMIT", 7: "QFULL",
          8: "BUSY", 9: "DISCONT", 10: "EEPROM"}
#: codes of a request that never ran (damaged on the way: checksum, syntax, unknown, too long)
NOT_EXECUTED = frozenset({1, 2, 3, 4})

#: a board line without its CR LF: printable body, ``*``, two upper-case hex digits
BOARD_LINE = re.compile(rb"^([\x20-\x7e]*)\*([0-9A-F]{2})$")
#: an integer as the board writes it (never ``+``, leading zeros or ``-0``)
STRICT_INT = re.compile(r"^(0|-?[1-9][0-9]{0,9})$")
#: an integer argument of a request (optional sign, 1 to 10 digits)
REQUEST_INT = re.compile(r"^[+-]?[0-9]{1,10}$")
#: the optional sequence id token of a request
REQUEST_SEQ = re.compile(r"^#([0-9]{1,5})$")
#: what may follow the last ``*`` of a request: two hex digits (either case), then blanks
REQUEST_CHECKSUM = re.compile(r"^[0-9A-Fa-f]{2}[ \t]*$")


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


def seal(body):
    """``body`` with its checksum appended, ``"<body>*HH"`` (no end of line).

    Parameters
    ----------
    body : str
        Line body (ASCII).

    Returns
    -------
    str
    """
    return f"{body}*{checksum(body):02X}"


def unseal(raw):
    """Body of a board line (bytes, without CR LF) whose checksum matches, else ``None``.

    Parameters
    ----------
    raw : bytes
        One line as received, end of line removed.

    Returns
    -------
    bytes or None
        The body before ``*HH``; ``None`` for a malformed line or a checksum mismatch.
    """
    m = BOARD_LINE.match(raw)
    if not m or int(m.group(2), 16) != checksum(m.group(1)):
        return None
    return m.group(1)


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


def crc16(data):
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) of the EEPROM image.

    Parameters
    ----------
    data : bytes-like

    Returns
    -------
    int
        0..65535.

    Examples
    --------
    >>> hex(crc16(b"123456789"))
    '0x29b1'
    """
    crc = 0xFFFF
    for b in bytes(data):
        crc ^= b << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


class CommandRejected(DeviceError):
    """The board answered ``ERR``: the request had no effect.

    Attributes
    ----------
    code : int
        Error code (key of :data:`ERRORS`).
    name : str
        Its name as the board sent it (``"LIMIT"``, ``"QFULL"`` ...).
    """

    def __init__(self, message, code, name):
        self.code = code
        self.name = name
        super().__init__(message)
