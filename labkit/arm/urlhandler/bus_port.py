"""The port of a real servo bus, ``dynamixel://<device>`` and ``feetech://<device>``.

URL form::

    dynamixel:///dev/ttyUSB0?baud=1000000        (U2D2, OpenRB-150 / OpenCM9.04 as a USB bridge)
    feetech:///dev/ttyACM0?baud=1000000          (SO-100 / SO-101 bus adapter board)
    dynamixel://COM4                              (Windows)

* the device is the bus adapter's serial port;
* ``baud``: the servos' baud rate [bit/s] (default: the robot file's ``[bus] baudrate``);
* ``queue``: the segment queue depth of the host-side board (default 6);
* ``latency``: the adapter's latency [ms] in the SDK's status-packet timeout (default: the SDK's 16 ms, an
  FTDI adapter's default latency timer; a U2D2 set to 1 ms may use less, a busy host more).

Any bus protocol of :data:`labkit.arm.bus.BUSES` is a scheme. The port holds a
:class:`labkit.arm.bus.BusBoard` on the wall clock (``clock=realtime``,
``time_scale=1``): :class:`labkit.arm.Arm` speaks labkit's protocol to it as to any board, and it
drives the servos through the vendor SDK. The robot (its ``[bus]`` table) is the one the
:class:`~labkit.arm.Arm` is opened with (``serial_for_url(url, robot=...)``).
"""

from __future__ import annotations

import time
import urllib.parse
from dataclasses import replace

from labkit.exceptions import PortURLError
from labkit.arm.urlhandler.board_serial import BoardSerial

__all__ = ["parse_bus_url", "BusSerial", "Serial"]


def parse_bus_url(url):
    """Split ``<protocol>://<device>?baud=..&queue=..`` into ``(protocol, device, options)``.

    Parameters
    ----------
    url : str

    Returns
    -------
    protocol : str
        A bus protocol of :data:`labkit.arm.bus.BUSES` (``"dynamixel"``, ``"feetech"`` ...).
    device : str
        The adapter's serial device.
    options : dict
        ``baud`` (int or None), ``queue`` (int), ``latency`` (float or None) [ms].

    Raises
    ------
    PortURLError
        Another scheme, no device, an unknown option or a malformed value.

    Examples
    --------
    >>> parse_bus_url("dynamixel:///dev/ttyUSB0?baud=57600")
    ('dynamixel', '/dev/ttyUSB0', {'baud': 57600, 'queue': 6, 'latency': None})
    """
    from labkit.arm.bus import BUSES

    parts = urllib.parse.urlsplit(url)
    if parts.scheme not in BUSES:
        raise PortURLError(f"expected a URL <bus>://<device> with <bus> one of {', '.join(BUSES)}, got {url!r}")
    device = urllib.parse.unquote(parts.netloc + parts.path)
    if not device:
        raise PortURLError(f"{url}: expected the bus adapter's device after {parts.scheme}:// "
                           f"(e.g. {parts.scheme}:///dev/ttyUSB0), got none")
    options = {"baud": None, "queue": 6, "latency": None}
    for key, values in urllib.parse.parse_qs(parts.query, keep_blank_values=True).items():
        if key not in options:
            raise PortURLError(f"{url}: unknown option {key!r}; valid options: {', '.join(options)}")
        try:
            options[key] = float(values[-1]) if key == "latency" else int(values[-1])
        except ValueError:
            kind = "a number [ms]" if key == "latency" else "an integer"
            raise PortURLError(f"{url}: option {key!r}: expected {kind}, got {values[-1]!r}") from None
    if options["latency"] is not None and not 0 <= options["latency"] <= 1000:
        raise PortURLError(f"{url}: expected latency 0..1000 ms, got {options['latency']:g}")
    if options["baud"] is not None and not 9600 <= options["baud"] <= 4_500_000:
        raise PortURLError(f"{url}: expected baud 9600..4500000 bit/s, got {options['baud']}")
    return parts.scheme, device, options


class BusSerial(BoardSerial):
    """A pyserial port holding a :class:`labkit.arm.bus.BusBoard` on a real bus (see the module notes).

    Parameters
    ----------
    *args, **kwargs
        As for ``serial.Serial``; ``robot`` (a Robot or robot file with a ``[bus]`` table) is required.
    """

    def __init__(self, *args, robot=None, **kwargs):
        self.robot = robot
        super().__init__(*args, **kwargs)

    def open(self):
        """Open the bus through its SDK and start the host-side board (pyserial calls this).

        Raises
        ------
        PortURLError
            A malformed URL, no robot file, or one whose ``[bus] protocol`` is not the URL's.
        """
        from labkit.arm.bus import open_bus_board
        from labkit.exceptions import OptionError
        from labkit.robot import Robot

        protocol, device, options = parse_bus_url(self.port)
        if self.robot is None:
            raise PortURLError(f"{self.port}: expected the robot file of the arm on the bus (Arm(robot, url) "
                               f"or serial_for_url(url, robot=...)), got none")
        robot = Robot.load(self.robot)
        if options["baud"] is not None and robot.bus is not None:
            robot = replace(robot, bus=replace(robot.bus, baudrate=options["baud"]))
        try:
            self.board = open_bus_board(robot, device, protocol=protocol, queue=options["queue"], name=self.port,
                                        latency=options["latency"])
        except OptionError as exc:
            raise PortURLError(str(exc)) from None
        self._clock = "realtime"
        self._scale = 1.0
        self._t0 = time.monotonic()
        self.is_open = True


#: the class pyserial's ``serial_for_url`` opens for ``<protocol>://`` (see :func:`labkit.arm.urlhandler.register`)
Serial = BusSerial
