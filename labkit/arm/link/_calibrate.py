"""``calibrate_bus``: a bus arm's guided calibration from a port URL to a written robot file.

The steps and the arithmetic are :func:`labkit.arm.bus.calibrate_servos`; the file is written by
:func:`labkit.robot.edit_bus_calibration` (in place with a backup, or to a new file). This module
opens what the URL names: a real bus (``dynamixel:///dev/ttyUSB0``, ``feetech:///dev/ttyACM0``, with
their ``baud`` and ``latency`` options), or a virtual one, ``sim://?bus=feetech&seed=3``: a
:class:`labkit.arm.bus.BusEmulator` whose servos are mounted at random (:func:`assembled_servos`,
the ``seed``; joint ``seed mod n`` across the encoder's seam), answered by its virtual hand.
"""

from __future__ import annotations

import difflib
import math
import os
from dataclasses import replace

from labkit.exceptions import OptionError, PortURLError
from labkit.robot import Robot, edit_bus_calibration
from labkit.arm.bus import BusEmulator, assembled_servos, calibrate_servos

__all__ = ["calibrate_bus"]


def _terminal(say):
    def ask(step):
        say(step.text)
        input("")

    return ask


def calibrate_bus(robot, port, *, out=None, ask=None, say=print, backup=True, write=True, rehome=True,
                  margin=math.radians(1.0), min_move=math.radians(5.0)):
    """Calibrate a bus arm by hand, step by step, and write its robot file's ``bus`` zeros, directions and limits.

    Parameters
    ----------
    robot : str or os.PathLike
        The robot file to calibrate (a bundled robot's name needs ``out``: labkit's own files are never
        changed).
    port : str
        ``<protocol>://<device>[?baud=..&latency=..]`` of the bus adapter, or ``sim://?bus=<protocol>&seed=N`` for
        a virtual bus with servos mounted at random (seed ``N``) and a virtual hand.
    out : str or os.PathLike, optional
        Write the calibrated robot file here; default: the robot file in place (the old one kept as ``.bak``).
    ask : callable, optional
        ``ask(step)`` returns once the student has done :class:`~labkit.arm.bus.CalibrationStep` ``step``;
        default: print the prompt and wait for Enter (a real bus), the virtual hand (``sim://``).
    say : callable
        Progress lines (default ``print``).
    backup : bool
        Keep the old file when writing in place.
    write : bool
        ``False``: compute and show only (no robot file, no homing offset written to a servo).
    rehome : bool
        Write a servo's homing offset when its range crosses the encoder's seam.
    margin, min_move : float
        As :func:`~labkit.arm.bus.calibrate_servos` [rad].

    Returns
    -------
    BusCalibration
        Before and after for every joint (``.table()``), the file written and its changed lines.

    Raises
    ------
    PortURLError
        ``port`` is not a bus URL or a ``sim://...?bus=...`` URL.
    OptionError, BusCalibrationError, DeviceError, RobotFileError
        As :func:`~labkit.arm.bus.calibrate_servos` and :func:`~labkit.robot.edit_bus_calibration`.

    Examples
    --------
    >>> result = calibrate_bus("my_so101.toml", "feetech:///dev/ttyACM0")   # doctest: +SKIP
    >>> print(result.table())                                                # doctest: +SKIP
    """
    from labkit.arm.bus import BUSES

    source = robot
    robot = Robot.load(robot)
    if write and out is None and not os.path.isfile(os.fspath(source)):
        raise OptionError(f"expected a robot file path to calibrate in place (or out= for a new file), got "
                          f"{os.fspath(source)!r}: labkit's bundled robot files are never changed")
    if robot.bus is None:
        raise OptionError(f"expected a robot file with a [bus] table to calibrate its servos, got {robot.name!r}")
    if not isinstance(port, str):
        raise PortURLError(f"expected the bus as a URL (dynamixel:///dev/ttyUSB0, sim://?bus=dynamixel&seed=0), "
                           f"got {port!r}")
    options = {"rehome": rehome, "margin": margin, "min_move": min_move, "say": say, "name": port,
               "write_offsets": write}
    emulator = None
    if port.startswith("sim:"):
        from labkit.arm.urlhandler.protocol_sim import VIRTUAL_BUS_LATENCY, parse_url

        named, physics, sim = parse_url(port)
        if sim["bus"] != robot.bus.protocol or (named and Robot.load(named).name != robot.name):
            raise PortURLError(f"{port}: expected sim://?bus={robot.bus.protocol}&seed=N for the {robot.bus.protocol} "
                               f"bus of {robot.name!r}, got bus {sim['bus'] or 'none'!r}"
                               + (f" and robot {named!r}" if named else ""))
        seed = int(physics.get("seed", 0))
        emulator = BusEmulator(robot, servos=assembled_servos(robot, seed, seam=(seed % robot.n,)))
        device, options["latency"] = emulator.path, VIRTUAL_BUS_LATENCY
        if ask is None:
            def ask(step):
                say(step.text)
                emulator.hand.answer(step)
    else:
        from labkit.arm.urlhandler.bus_port import parse_bus_url

        if port.split(":", 1)[0] not in BUSES:
            raise PortURLError(f"expected a bus URL <bus>://<device> with <bus> one of {', '.join(BUSES)}, or "
                               f"sim://?bus=...&seed=N, got {port!r}")
        protocol, device, url_options = parse_bus_url(port)
        if protocol != robot.bus.protocol:
            raise PortURLError(f"{port}: expected a {robot.bus.protocol}:// bus for {robot.name!r}, got {protocol}://")
        if url_options["baud"] is not None:
            robot = replace(robot, bus=replace(robot.bus, baudrate=url_options["baud"]))
        options["latency"] = url_options["latency"]
        ask = _terminal(say) if ask is None else ask
    try:
        result = calibrate_servos(robot, device, ask=ask, **options)
    finally:
        if emulator is not None:
            emulator.close()
    if not write:
        return result
    before, after, saved = edit_bus_calibration(source, result.changes(), out=out, backup=backup)
    target = os.fspath(out) if out is not None else os.fspath(robot.path)
    diff = "".join(difflib.unified_diff(before.splitlines(True), after.splitlines(True), "before", "after", n=0))
    return replace(result, path=target, backup=None if saved is None else os.fspath(saved), diff=diff)
