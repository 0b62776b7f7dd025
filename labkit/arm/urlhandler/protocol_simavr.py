"""pyserial URL handler ``simavr://[path/to/firmware.elf][?options]``: the real firmware in simavr.

Opening the URL builds the firmware and harness if needed, starts the simulator with the CPU
held, opens the harness's pty and only then lets the CPU run, so the ``READY`` line is not
lost to pyserial's input flush on open. Closing the port stops the simulator.

Options (query string):

``pace=<factor>``
    0 (default) runs free (about 10x real time), 1 paces simulated time to the wall clock.
``tick=<seconds>``
    period of the ``on_tick`` hook (default 0.005 s of simulated time).
``physics=<robot>``
    close the loop with labkit's arm model: the servo pulses the firmware emits drive the
    same :class:`labkit.arm.ArmModel` the ``sim://`` virtual arm uses (servo dynamics,
    sag, offsets, noise), whose joint angles come back on the feedback pins. ``<robot>`` is
    a bundled robot name or robot file (``1`` means ``arduino_arm_3dof``); default: off,
    the feedback pins read whatever ``port.sim.set_analog`` set.
``seed=<int>``
    seed of the arm model's random errors (default 0; only with ``physics``).

The simulator is available as ``port.sim`` (a :class:`labkit.arm.FirmwareSim`):
``port.sim.pulses()``, ``port.sim.set_analog(pin, volts)``, ``port.sim.reset()``..., and
with ``physics`` the model as ``port.physics`` (a :class:`labkit.arm.FirmwareAdapter`;
``port.physics.model`` has the virtual ruler).

Example
-------
>>> import serial, labkit.arm.urlhandler
>>> labkit.arm.urlhandler.register()
>>> port = serial.serial_for_url("simavr://?pace=1", baudrate=115200, timeout=1)  # doctest: +SKIP
>>> port.readline()                                                               # doctest: +SKIP
b'READY labkit-arm 2 fw=2.1.0 proto=2 joints=3 reset=POWER eeprom=DEFAULTS*851D\\r\\n'
"""

from __future__ import annotations

import urllib.parse

from serial import serialposix
from serial.serialutil import SerialException

from labkit.arm._firmware import FirmwareSim

SCHEME = "simavr://"


_DEFAULTS = {"pace": 0.0, "tick": 0.005, "physics": "", "seed": 0}


def parse_url(url):
    """Split ``simavr://[elf][?options]`` into ``(elf or None, options)``.

    Parameters
    ----------
    url : str
        ``simavr://[path/to/firmware.elf][?pace=..&tick=..&physics=..&seed=..]``.

    Returns
    -------
    elf : str or None
        Firmware ELF to load (None: the one built from ``firmware/``).
    options : dict
        ``pace`` (float), ``tick`` [s] (float), ``physics`` (robot name/path, "" for off),
        ``seed`` (int).

    Raises
    ------
    serial.SerialException
        For another scheme or unknown/malformed options.
    """
    if not url.lower().startswith(SCHEME):
        raise SerialException(f"expected a URL starting with {SCHEME!r}, got {url!r}")
    rest = url[len(SCHEME):]
    path, _, query = rest.partition("?")
    options = dict(_DEFAULTS)
    for key, values in urllib.parse.parse_qs(query, keep_blank_values=True).items():
        if key not in options:
            raise SerialException(f"unknown option {key!r} in {url!r}; valid options: {sorted(options)}")
        value = values[-1]
        if key == "physics":
            options[key] = {"0": "", "1": "arduino_arm_3dof"}.get(value, value)
            continue
        try:
            options[key] = int(value) if key == "seed" else float(value)
        except ValueError:
            kind = "an integer" if key == "seed" else "a number"
            raise SerialException(f"option {key!r} in {url!r} must be {kind}, got {value!r}") from None
    return (urllib.parse.unquote(path) or None), options


class Serial(serialposix.Serial):
    """A pyserial port on the simulated Uno's UART0 (see module docstring)."""

    sim: FirmwareSim | None = None
    physics = None

    def open(self):
        """Start the simulator (and the arm model with ``physics``), open its pty, then run the CPU."""
        url = self._port
        elf, options = parse_url(url)
        on_tick = None
        if options["physics"]:
            from labkit.arm._model import FirmwareAdapter
            from labkit.arm._physics import PhysicsConfig

            try:
                self.physics = FirmwareAdapter(options["physics"], PhysicsConfig(seed=options["seed"]))
            except Exception as exc:
                raise SerialException(f"could not set up the arm model for {url!r}: {exc}") from exc
            on_tick = self.physics.on_tick
        try:
            self.sim = FirmwareSim(elf, pace=options["pace"], tick_period=options["tick"], on_tick=on_tick)
        except Exception as exc:
            raise SerialException(f"could not start the firmware simulator for {url!r}: {exc}") from exc
        self._port = self.portstr = self.sim.port
        try:
            super().open()
        except Exception:
            self.sim.close()
            self.sim = None
            raise
        finally:
            self._port = self.portstr = url
        self.sim.run()

    def close(self):
        """Close the pty and stop the simulator."""
        super().close()
        if self.sim is not None:
            self.sim.close()
            self.sim = None
