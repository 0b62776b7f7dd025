"""pyserial URL handler ``simavr://[path/to/firmware.elf][?options]``: the real firmware in simavr.

Opening the URL builds the firmware and harness if needed, starts the simulator with the CPU
held, opens the harness's pty and only then lets the CPU run, so the ``READY`` line is not
lost to pyserial's input flush on open. Closing the port stops the simulator.

The port is a :class:`labkit.arm.SimavrPort`: :class:`labkit.arm.Arm` keeps its clock, waits and
reply timeouts in *simulated* time (``port.board_time``), as on ``sim://``.

Options (query string):

``clock=lockstep|realtime``
    ``lockstep`` (the default with ``pace=0``): the simulated CPU runs only while the host waits
    on the port (a read runs it until the board completes a line or the read timeout's seconds of
    simulated time have passed; ``port.sleep(s)`` and ``port.sim.sleep(s)`` run ``s``). Simulated
    time stands still while the host computes or is descheduled, so a run is deterministic and
    a loaded machine cannot trip the firmware's host-silence timer; a 50 ms reply timeout costs
    50 ms of simulated time, a few ms of wall time. ``realtime`` (the default with ``pace > 0``):
    the simulator runs on its own, free (``pace=0``, about 10x real time) or paced, and reads wait
    on the wall clock. ``clock=lockstep`` with ``pace > 0`` is refused (the two contradict).
``pace=<factor>``
    0 (default) runs as fast as the simulator goes; ``f > 0`` (``realtime`` clock) paces
    simulated time to ``f`` x the wall clock (1: like a real board).
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
>>> port = serial.serial_for_url("simavr://", baudrate=115200, timeout=1)   # doctest: +SKIP
>>> port.clock, port.readline()                                           # doctest: +SKIP
('lockstep', b'READY labkit-arm 3 fw=3.0.0 proto=3 joints=3 reset=POWER eeprom=DEFAULTS*8B079DC6\\r\\n')
>>> port.sim.sleep(1.5); round(port.board_time, 3)                        # doctest: +SKIP
1.502
"""

from __future__ import annotations

import urllib.parse

from labkit.arm.simavr import CLOCKS, FirmwareSim, SimavrPort
from labkit.arm._port_errors import PortError, PortURLError

SCHEME = "simavr://"


_DEFAULTS = {"pace": 0.0, "tick": 0.005, "physics": "", "seed": 0, "clock": ""}


def parse_url(url):
    """Split ``simavr://[elf][?options]`` into ``(elf or None, options)``.

    Parameters
    ----------
    url : str
        ``simavr://[path/to/firmware.elf][?clock=..&pace=..&tick=..&physics=..&seed=..]``.

    Returns
    -------
    elf : str or None
        Firmware ELF to load (None: the one built from ``firmware/``).
    options : dict
        ``pace`` (float), ``tick`` [s] (float), ``physics`` (robot name/path, "" for off),
        ``seed`` (int), ``clock`` (``"lockstep"`` or ``"realtime"``; by default lockstep
        when ``pace`` is 0).

    Raises
    ------
    labkit.arm.urlhandler.protocol_sim.PortURLError
        For another scheme or unknown/malformed options (a :class:`labkit.exceptions.OptionError`
        that is also a ``serial.SerialException``).
    """
    if not url.lower().startswith(SCHEME):
        raise PortURLError(f"expected a URL starting with {SCHEME!r}, got {url!r}")
    rest = url[len(SCHEME):]
    path, _, query = rest.partition("?")
    options = dict(_DEFAULTS)
    for key, values in urllib.parse.parse_qs(query, keep_blank_values=True).items():
        if key not in options:
            raise PortURLError(f"unknown option {key!r} in {url!r}; valid options: {sorted(options)}")
        value = values[-1]
        if key == "physics":
            options[key] = {"0": "", "1": "arduino_arm_3dof"}.get(value, value)
            continue
        if key == "clock":
            if value not in CLOCKS:
                raise PortURLError(f"option 'clock' in {url!r} must be one of {', '.join(CLOCKS)}, got {value!r}")
            options[key] = value
            continue
        try:
            options[key] = int(value) if key == "seed" else float(value)
        except ValueError:
            kind = "an integer" if key == "seed" else "a number"
            raise PortURLError(f"option {key!r} in {url!r} must be {kind}, got {value!r}") from None
    if options["pace"] < 0:
        raise PortURLError(f"option 'pace' in {url!r} must be >= 0, got {options['pace']:g}")
    if not options["clock"]:
        options["clock"] = "lockstep" if options["pace"] == 0 else "realtime"
    elif options["clock"] == "lockstep" and options["pace"] > 0:
        raise PortURLError(f"{url!r}: clock=lockstep runs the simulator only while the host waits, "
                              f"it cannot also be paced (pace={options['pace']:g}); use pace=0 or clock=realtime")
    return (urllib.parse.unquote(path) or None), options


class Serial(SimavrPort):
    """A pyserial port on the simulated Uno's UART0 (see module docstring)."""


    def open(self):
        """Start the simulator (and the arm model with ``physics``), open its pty, then run the CPU."""
        url = self._port
        elf, options = parse_url(url)
        on_tick = None
        if options["physics"]:
            from labkit.arm.board import FirmwareAdapter, PhysicsConfig

            try:
                self.physics = FirmwareAdapter(options["physics"], PhysicsConfig(seed=options["seed"]))
            except Exception as exc:  # a ValueError: the robot or physics the URL names
                error = PortURLError if isinstance(exc, ValueError) else PortError
                raise error(f"could not set up the arm model for {url!r}: {exc}") from exc
            on_tick = self.physics.on_tick
        try:
            self.sim = FirmwareSim(elf, pace=options["pace"], tick_period=options["tick"], on_tick=on_tick)
        except Exception as exc:
            raise PortError(f"could not start the firmware simulator for {url!r}: {exc}") from exc
        self._clock = options["clock"]
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
