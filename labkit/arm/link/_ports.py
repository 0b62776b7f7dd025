"""Real-board start-up (private; the public names are re-exported by :mod:`labkit.arm`).

A real board's pyserial port as a :class:`labkit.arm.BoardPort` (:class:`ArduinoPort`); which serial ports exist and which look like an Arduino (pyserial's
:func:`serial.tools.list_ports.comports`, USB vendor/product ids); opening
one with errors that say what to do: a port held by another program (the
Arduino IDE's serial monitor) or one the user may not open (Linux: the
``dialout`` group); and the handshake: wait for the board's ``READY`` (an Uno
resets when its port opens), refuse a board of an older protocol (1: XOR
checksums, 2: CRC-16), ``HELLO``.

Examples
--------
>>> [p.device for p in list_ports() if p.arduino] == find_ports()
True
"""

from __future__ import annotations

import errno
import sys
import time
from dataclasses import dataclass

from labkit.exceptions import DeviceError, OptionError, ProtocolError
from labkit.robot import Robot
from labkit.arm._board_port import BoardPort
from labkit.arm._faults import PortWrapper
from labkit.arm._protocol import PROTOCOL_VERSION
from labkit.arm.link._replies import BoardInfo, parse_hello

__all__ = ["ArduinoPort", "PortInfo", "list_ports", "find_ports"]

#: USB vendor ids of Arduino boards and the USB-serial chips of common clones
#: oldest firmware the host drives: 3.0.0 speaks protocol 3 (every line sealed with a CRC-32); before it 2.1.0 gave
#: ``MOVE`` a duration checked against the speed limits, 2.2.0 answers a repeated sealed request without running
#: it (the host resends a request under the same ``#seq``), 2.3.0 refuses a stale one (a late copy never runs)
MIN_FIRMWARE = (3, 0, 0)
_MIN_TEXT = ".".join(map(str, MIN_FIRMWARE))

ARDUINO_VIDS = {0x2341: "Arduino", 0x2A03: "Arduino.org", 0x1A86: "CH340 (clone)", 0x10C4: "CP210x",
                0x239A: "Adafruit"}
#: USB vendor ids of the USB-serial chips of servo-bus adapters (ROBOTIS U2D2: FTDI FT232H), not taken for an Arduino
BUS_ADAPTER_VIDS = {0x0403: "FTDI"}


class ArduinoPort(PortWrapper):
    """A pyserial port to a real board (an Arduino running labkit's firmware) as a :class:`BoardPort`.

    Bytes, ``timeout`` and everything else go to the wrapped port; the host keeps the wall clock
    (``board_time`` is ``None``, ``clock`` ``"realtime"`` at ``time_scale`` 1, :meth:`sleep` sleeps), the
    board's joints come back only as protocol lines (:meth:`read_servos` is ``None``) and nothing is
    simulated (``virtual_model`` is ``None``).

    Parameters
    ----------
    port : serial-like
        An open pyserial port (or any object with pyserial's ``read``, ``write``, ``in_waiting``,
        ``timeout`` and ``close``).
    """

    board_time = None
    clock = "realtime"
    time_scale = 1.0
    virtual_model = None

    def sleep(self, seconds):
        """Wait ``seconds`` of the wall clock.

        Parameters
        ----------
        seconds : float
        """
        time.sleep(seconds)

    def read_servos(self):
        """``None``: a real board reports its joints as ``READ`` and ``FB`` lines.

        Returns
        -------
        None
        """
        return None

    def servo_bus(self):
        """``None``: the board drives hobby servos, which have no bus to reach.

        Returns
        -------
        None
        """
        return None

    def servo_stream(self):
        """``None``: a real board's stream frames travel as ``FB`` lines.

        Returns
        -------
        None
        """
        return None


def board_port(port):
    """``port`` as a :class:`BoardPort`: as it is if it is one, else a real board's port (:class:`ArduinoPort`).

    Parameters
    ----------
    port : serial-like
        An open port.

    Returns
    -------
    BoardPort
    """
    return port if isinstance(port, BoardPort) else ArduinoPort(port)


@dataclass(frozen=True)
class PortInfo:
    """One serial port: device name, USB ids, description, and whether it looks like an Arduino or a bus adapter.

    Attributes
    ----------
    device : str
        ``/dev/ttyACM0``, ``COM3`` ...
    vid, pid : int or None
        USB vendor and product id (``None`` for a port that is not USB).
    description : str
        What the operating system calls it.
    arduino : bool
        The vendor id or the description says Arduino (or a common clone chip).
    bus_adapter : bool
        Not an Arduino, but a USB-serial chip that servo-bus adapters use (FTDI, as in a ROBOTIS U2D2) or a
        description naming one: possibly a Dynamixel or Feetech bus (``dynamixel://<device>``,
        ``feetech://<device>``).
    """

    device: str
    vid: int | None
    pid: int | None
    description: str
    arduino: bool
    bus_adapter: bool = False

    @property
    def usb_id(self):
        """``"VID:PID"`` in hex (``"2341:0043"``), or ``"-"`` for a port that is not USB.

        Returns
        -------
        str
        """
        return "-" if self.vid is None else f"{self.vid:04X}:{(self.pid or 0):04X}"


def list_ports():
    """Every serial port pyserial sees, likely Arduinos first, then possible servo-bus adapters.

    Returns
    -------
    list of PortInfo
        Sorted: Arduino-like before bus adapters before others, ``ACM`` devices (native USB) before ``USB`` ones.
    """
    from serial.tools import list_ports as lp

    found = []
    for p in lp.comports():
        text = f"{p.description} {p.manufacturer or ''}".lower()
        arduino = p.vid in ARDUINO_VIDS or "arduino" in text or "ch340" in text
        bus = not arduino and (p.vid in BUS_ADAPTER_VIDS or "u2d2" in text)
        found.append(PortInfo(p.device, p.vid, p.pid, p.description or "", bool(arduino), bool(bus)))
    return sorted(found, key=lambda p: (not p.arduino, not p.bus_adapter, "ACM" not in p.device, p.device))


def find_ports():
    """Serial ports that look like an Arduino (USB VID or description), best first; bus adapters are not among them.

    Returns
    -------
    list of str
        Device names (``/dev/ttyACM0``, ``COM3`` ...).
    """
    return [p.device for p in list_ports() if p.arduino]


def first_arduino():
    """The first of :func:`find_ports` (what ``Arm(robot)`` without a port opens).

    Returns
    -------
    str

    Raises
    ------
    DeviceError
        No Arduino-like port; the message names a possible servo-bus adapter if there is one.
    """
    ports = list_ports()
    arduinos = [p.device for p in ports if p.arduino]
    if arduinos:
        return arduinos[0]
    bus = [p.device for p in ports if p.bus_adapter]
    hint = (f"; {bus[0]} may be a servo-bus adapter (FTDI, e.g. a U2D2): open it as 'dynamixel://{bus[0]}' or "
            f"'feetech://{bus[0]}' with the arm's robot file" if bus else "")
    raise DeviceError("no Arduino-like serial port found ('labkit ports' lists them); plug the board in, name the "
                      f"port (e.g. '/dev/ttyACM0', 'COM3'), or use the virtual arm 'sim://'{hint}")


def arm_robot(robot, port):
    """The robot and port of ``Arm(robot, port)``: ``robot`` loaded, or with ``None`` the one a ``sim://`` port names.

    A URL given alone (``Arm("sim://openmanipulator_x?bus=dynamixel")``, ``robot`` a string with ``://`` and
    ``port`` ``None``) is the port, and its robot the one it names.

    Parameters
    ----------
    robot : Robot or str or None
    port : str or serial-like or None

    Returns
    -------
    robot : Robot
    port : str or serial-like or None

    Raises
    ------
    OptionError
        ``robot`` is ``None`` and ``port`` is not a ``sim://`` URL naming a robot.
    """
    from labkit.arm.urlhandler.protocol_sim import parse_url

    if port is None and isinstance(robot, str) and "://" in robot:  # Arm(url): the URL is the port
        robot, port = None, robot
    if robot is None and isinstance(port, str) and port.lower().startswith("sim://"):
        robot = parse_url(port)[0] or None
    if robot is None:
        raise OptionError("expected the arm's robot (Arm(robot, port): a bundled robot name, a robot file or a "
                          f"Robot), or robot=None with a port sim://<robot>?... that names one; got robot=None and "
                          f"port {port!r}")
    return Robot.load(robot), port


def open_port(port, baudrate, robot=None):
    """Open ``port`` (device name or pyserial URL) with an error that says what to do.

    Parameters
    ----------
    port : str
        Device name or URL (``sim://``, ``simavr://``, ``dynamixel://``, ``feetech://``...).
    baudrate : int
        Baud rate [bit/s] (of a board; a servo bus runs at its robot file's ``[bus] baudrate``).
    robot : Robot, optional
        The arm's robot file, handed to a servo-bus URL (``dynamixel://``, ``feetech://``) for its ``[bus]`` table
        and to a ``sim://`` URL that names no robot (the virtual arm is then a copy of it).

    Returns
    -------
    BoardPort
        The open port (read timeout 0.05 s); a device's pyserial port wrapped in an :class:`ArduinoPort`.

    Raises
    ------
    DeviceError
        The port does not exist, is held by another program, or may not be opened by this user.
    """
    import serial
    from labkit.arm.bus import BUSES

    scheme = str(port).split("://", 1)[0].lower() if "://" in str(port) else ""
    bus = {"robot": robot} if robot is not None and (scheme in BUSES or scheme == "sim") else {}
    try:
        return board_port(serial.serial_for_url(port, baudrate=baudrate, timeout=0.05, **bus))
    except (serial.SerialException, OSError, ValueError) as exc:
        if bus and isinstance(exc, DeviceError):  # a silent servo, an arm outside its limits: the message says
            raise
        code = getattr(exc, "errno", None)
        text = str(exc)
        if code == errno.EBUSY or "busy" in text.lower() or (sys.platform == "win32" and "denied" in text.lower()):
            hint = ("the port is in use by another program: close the Arduino IDE's serial monitor "
                    "(or screen, minicom, another labkit session) and try again")
        elif code in (errno.EACCES, errno.EPERM) or "permission denied" in text.lower():
            hint = ("permission denied: on Linux add yourself to the 'dialout' group "
                    "(sudo usermod -aG dialout $USER), then log out and in again")
        elif code == errno.ENOENT or "no such file" in text.lower():
            hint = "no such port: is the board plugged in? 'labkit ports' lists the serial ports"
        else:
            hint = "'labkit ports' lists the serial ports"
        raise DeviceError(f"cannot open {port!r}: {text}; {hint}") from None


def handshake(arm, boot_wait):
    """Wait for ``READY``, refuse an older board, ``HELLO``, check the joints, read ``STATUS last=``.

    Parameters
    ----------
    arm : labkit.arm.Arm
        The connection being opened (its wire object and robot).
    boot_wait : float
        Longest wait for ``READY`` [s]; without it ``HELLO`` is still tried.

    Raises
    ------
    DeviceError
        No ``READY`` and no answer, a board of an older protocol (1 or 2), another protocol version or joint
        count.
    ProtocolError
        The device answers ``HELLO`` but is not a labkit arm.
    """
    wire = arm._wire
    ready = wire.wait_ready(boot_wait)
    _refuse_old(arm)
    if ready is not None and (ready[:1] != ["labkit-arm"] or ready[1:2] != [str(PROTOCOL_VERSION)]):
        raise DeviceError(f"{arm.name}: the board announced {' '.join(ready)!r}, labkit expects "
                          f"'labkit-arm {PROTOCOL_VERSION}'; flash firmware/labkit_arm (README) or update labkit")
    try:
        info = wire.transact("HELLO", parse=parse_hello)
    except DeviceError as exc:
        _refuse_old(arm)
        if ready is None:
            raise DeviceError(
                f"{arm.name}: no READY from the board within {boot_wait:g} s after opening the port, and "
                f"no answer to HELLO ({exc}); is the labkit firmware flashed (README: 'Flash the "
                f"firmware'), the baud rate 115200 and the right port chosen (labkit ports)?") from None
        raise DeviceError(f"{arm.name}: no handshake with the board ({exc})") from None
    if not isinstance(info, BoardInfo):
        raise ProtocolError(f"{arm.name}: not a labkit arm: HELLO answered {info!r}")
    wire.info = info
    if info.protocol != PROTOCOL_VERSION:
        raise DeviceError(f"{arm.name}: the board (firmware {info.firmware}) speaks protocol {info.protocol}, "
                          f"labkit expects protocol {PROTOCOL_VERSION} (firmware {_MIN_TEXT} or newer); "
                          f"flash firmware/labkit_arm or update labkit")
    if _version(info.firmware) < MIN_FIRMWARE:
        raise DeviceError(f"{arm.name}: the board runs labkit firmware {info.firmware}; labkit needs "
                          f"{_MIN_TEXT} or newer (protocol {PROTOCOL_VERSION}: a CRC-32 on every line): "
                          f"flash firmware/labkit_arm (make -C firmware, then avrdude or the Arduino IDE, see README)")
    if info.joints != arm.robot.n:
        raise DeviceError(f"{arm.name}: board has {info.joints} joints, robot "
                          f"{arm.robot.name} has {arm.robot.n}")
    # what ran before this connection is not ours to judge; our seqs follow it, so that none of them is
    # taken for a repeat of a request the board remembers from an earlier connection
    wire.last_seq = arm._verify_status()[0].last
    wire.follow(wire.last_seq)


def _version(text):
    """``"2.1.0"`` -> ``(2, 1, 0)``; an unreadable version sorts first."""
    try:
        return tuple(int(part) for part in text.split("."))
    except ValueError:
        return (-1,)


def _refuse_old(arm):
    """Raise if the board sent an intact line of an older protocol (1: XOR checksums, 2: CRC-16)."""
    if arm._wire.old_seen is None:
        return
    proto, line = arm._wire.old_seen
    fw = next((t[3:] for t in line.rpartition("*")[0].split() if t.startswith("fw=")), None)
    which = f"labkit firmware {fw}, protocol {proto}" if fw else f"an older labkit firmware, protocol {proto}"
    raise DeviceError(f"{arm.name}: the board runs {which} ({line!r}); labkit speaks protocol {PROTOCOL_VERSION} "
                      f"(firmware {_MIN_TEXT} or newer: a CRC-32 on every line): flash firmware/labkit_arm "
                      f"(make -C firmware, then avrdude or the Arduino IDE, see README)")
