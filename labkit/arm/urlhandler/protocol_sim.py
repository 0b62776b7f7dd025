"""pyserial URL handler ``sim://``: a serial port wired to labkit's virtual arm.

URL form::

    sim://[robot]?seed=0&time_scale=1&clock=realtime&<physics option>=<value>...

* ``robot``: bundled robot name or robot file; without one in the URL, the ``robot=`` option of
  ``serial.serial_for_url(url, robot=...)`` (which :class:`labkit.arm.Arm` passes: ``Arm(robot, "sim://")``
  is a virtual copy of ``robot``); there is no default arm;
* ``seed``: physics seed (offsets, noise, ruler);
* ``clock``: ``realtime`` (board time = ``time_scale`` x wall clock) or
  ``lockstep`` (board time advances only while the host waits in ``read``,
  by the read timeout, or in :meth:`Serial.sleep`; deterministic and as fast
  as the host can go, for tests);
* ``time_scale``: board seconds per wall-clock second (realtime clock);
* ``calibrated``: ``1`` boots a board whose EEPROM already holds the robot file's servo
  calibration (saved with ``CAL`` + ``SAVE``), so the joints start at the middle of their
  limits; default ``0``, the factory calibration (every servo centred at 90 deg), under which
  a robot whose limits exclude 90 deg cannot be calibrated;
* ``bus``: a bus protocol (:data:`labkit.arm.bus.BUSES`: ``dynamixel``, ``feetech``) puts a virtual servo bus between the board and the arm: the
  robot file's ``[bus]`` table names the servos, a :class:`labkit.arm.bus.BusEmulator` serves them on a
  pseudo-terminal and a :class:`labkit.arm.bus.BusBoard` drives them through the vendor SDK (default:
  none, the hobby-servo board); the bus's physics has no deadband unless ``deadband`` is given;
* ``queue``: segment queue depth; any field of
  :class:`labkit.arm.PhysicsConfig` (``deadband=0``, ``zero_offsets=0.01,0,0``...).

Examples
--------
>>> import serial
>>> from labkit.arm.urlhandler import register
>>> register()
>>> port = serial.serial_for_url("sim://arduino_arm_3dof?clock=lockstep&seed=1", timeout=0.5)
>>> port.readline()[:19]
b'READY labkit-arm 3 '
>>> port.close()
"""

from __future__ import annotations

import dataclasses
import time
import urllib.parse

from labkit.exceptions import PortError, PortURLError
from labkit.arm.urlhandler.board_serial import BoardSerial

CLOCKS = ("realtime", "lockstep")
#: the adapter latency [ms] the SDK's status timeouts assume on a virtual bus (a loaded host answers late)
VIRTUAL_BUS_LATENCY = 100.0


def _parse_value(field, text):
    if field.name == "seed":
        return int(text)
    if "," in text or field.name in ("zero_offsets", "link_masses", "gravity"):
        return tuple(float(v) for v in text.split(",") if v != "")
    if text.lower() == "none":
        return None
    return float(text)


def parse_url(url):
    """Split a ``sim://`` URL into ``(robot, physics kwargs, options)``.

    Parameters
    ----------
    url : str
        ``sim://[robot]?option=value&...`` (see the module docstring).

    Returns
    -------
    robot : str
        Bundled robot name or robot file; ``""`` if the URL names none.
    physics : dict
        :class:`labkit.arm.PhysicsConfig` fields given in the URL.
    options : dict
        ``clock`` (str), ``time_scale`` (float), ``queue`` (int), ``calibrated`` (bool), ``bus`` (str, "" for none).

    Raises
    ------
    PortURLError
        For another scheme, an unknown option (the message lists the valid ones) or a malformed value;
        also a ``serial.SerialException``.
    """
    from labkit.arm.board import PhysicsConfig
    from labkit.arm.bus import BUSES

    parts = urllib.parse.urlsplit(url)
    if parts.scheme != "sim":
        raise PortURLError(f"expected a URL of the form sim://[robot]?seed=..., got {url!r}")
    robot = urllib.parse.unquote(parts.netloc + parts.path)
    fields = {f.name: f for f in dataclasses.fields(PhysicsConfig)}
    physics, options = {}, {"clock": "realtime", "time_scale": 1.0, "queue": 6, "calibrated": False, "bus": ""}
    for key, values in urllib.parse.parse_qs(parts.query, keep_blank_values=True).items():
        value = values[-1]
        try:
            if key in fields:
                physics[key] = _parse_value(fields[key], value)
            elif key == "clock":
                if value not in CLOCKS:
                    raise PortURLError(f"{url}: expected clock one of {', '.join(CLOCKS)}, got {value!r}")
                options["clock"] = value
            elif key == "time_scale":
                options["time_scale"] = float(value)
                if not options["time_scale"] > 0:
                    raise PortURLError(f"{url}: expected time_scale > 0, got {value}")
            elif key == "queue":
                options["queue"] = int(value)
            elif key == "calibrated":
                if value not in ("0", "1"):
                    raise PortURLError(f"{url}: expected calibrated=0 or 1, got {value!r}")
                options["calibrated"] = value == "1"
            elif key == "bus":
                if value not in BUSES:
                    raise PortURLError(f"{url}: expected bus one of {', '.join(BUSES)}, got {value!r}")
                options["bus"] = value
            else:
                valid = ", ".join(["clock", "time_scale", "queue", "calibrated", *fields, "bus"])
                raise PortURLError(f"{url}: unknown option {key!r}; valid options: {valid}")
        except PortURLError:  # an OptionError, hence a ValueError: already says what is wrong
            raise
        except ValueError as exc:  # a malformed number
            kind = "an integer" if key in ("seed", "queue") else "numbers" if "," in value else "a number"
            raise PortURLError(f"{url}: option {key!r}: expected {kind}, got {value!r} ({exc})") from None
    return robot, physics, options


class Serial(BoardSerial):
    """A pyserial port whose other end is a :class:`labkit.arm.VirtualBoard` or, with ``bus=``, a
    :class:`labkit.arm.bus.BusBoard` on a virtual bus (attribute ``board``; see :class:`BoardSerial`).

    Parameters
    ----------
    *args, **kwargs
        As for ``serial.Serial``; ``robot`` (a Robot, bundled robot name or robot file) is the simulated
        arm when the URL names none (``sim://?seed=1``).
    """

    def __init__(self, *args, robot=None, **kwargs):
        #: the robot of ``serial_for_url(url, robot=...)``, used when the URL names none
        self.robot = robot
        #: the virtual servo bus of ``bus=...`` (a :class:`labkit.arm.bus.BusEmulator`), else None
        self.emulator = None
        super().__init__(*args, **kwargs)

    # -- pyserial plumbing ---------------------------------------------------------
    def open(self):
        """Create the virtual board the URL describes (pyserial calls this on construction)."""
        from labkit.arm.board import PhysicsConfig, VirtualBoard

        if self.is_open:
            raise PortError(f"{self._port}: expected a closed port to open, got one already open")
        if self._port is None:
            raise PortError("expected a sim:// URL as the port to open, got none (port=None)")
        robot, physics, options = parse_url(self.port)
        if not robot:
            if self.robot is None:
                raise PortURLError(f"{self.port}: expected a robot, named in the URL (sim://<robot>?..., e.g. "
                                   "sim://arduino_arm_3dof?seed=0) or given as the robot= option "
                                   "(serial_for_url(url, robot=...); Arm(robot, url) passes its own), got none")
            robot = self.robot
        try:
            if options["bus"]:
                self._open_bus(robot, PhysicsConfig(**{"deadband": 0.0, **physics}), options)
            else:
                config = PhysicsConfig(**physics)
                self.board = VirtualBoard(robot, config, queue=options["queue"],
                                          saved_calibration=options["calibrated"])
        except ValueError as exc:  # a robot or physics value the URL gives
            raise PortURLError(f"{self.port}: {exc}") from None
        except OSError as exc:  # a robot file that cannot be read
            raise PortError(f"{self.port}: {exc}") from None
        self._clock = options["clock"]
        self._scale = options["time_scale"]
        self._t0 = time.monotonic()
        self.is_open = True

    def _open_bus(self, robot, config, options):
        from labkit.arm.bus import BusEmulator, open_bus_board

        self.emulator = BusEmulator(robot, config)
        try:
            self.board = open_bus_board(robot, self.emulator.path, protocol=options["bus"], model=self.emulator.model,
                                        queue=options["queue"], name=self.port, latency=VIRTUAL_BUS_LATENCY)
        except BaseException:
            self.emulator.close()
            raise

    def close(self):
        """Close the port; the board object stays inspectable (a bus board turns torque off, its bus closes)."""
        super().close()
        if self.emulator is not None:
            self.emulator.close()
