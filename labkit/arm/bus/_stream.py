"""Streams of a servo bus: every frame one sync read of positions and currents, as a table.

On a bus the host-side :class:`BusBoard` takes the readings itself (a sync read per frame at the
stream rate, on its board clock; the port's ``servo_stream``), so nothing travels as ``FB`` lines and nothing is lost between
board and host: a lost or corrupt status packet on the bus is a :class:`BusFault`, not a gap.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from labkit.exceptions import DeviceError, OptionError

__all__ = ["record_bus_stream"]


def _ping(fields):
    return int(fields[0]) / 1000.0


def record_bus_stream(robot, wire, duration, hz):
    """Record ``duration`` s of a bus board's stream (:meth:`labkit.arm.Arm.stream` on a servo bus).

    Parameters
    ----------
    robot : labkit.robot.Robot
        The robot with the ``[bus]`` table.
    wire : object
        The link's wire (``transact``, ``pump``, ``clock``, ``io``, ``port``); its port (a
        :class:`labkit.arm.BoardPort`) offers the frames (``servo_stream``).
    duration : float
        Recording time [s of board time], > 0.
    hz : int
        Frame rate [Hz], a whole number 1..200.

    Returns
    -------
    pandas.DataFrame
        One row per frame: ``t`` [s, board clock], ``counter``, ``tick<i>`` [ticks], ``q_<name>`` [rad]
        and ``current_<name>`` [A] of every joint; ``df.attrs``: ``expected`` (frames due in the window),
        ``lost`` (0: a bus that loses a status packet stops with a :class:`BusFault`), ``rejected`` (0) and ``hz``.

    Raises
    ------
    OptionError
        ``duration`` not > 0 s or ``hz`` not a whole number 1..200.
    DeviceError
        The port holds no bus board, or the bus failed.
    """
    import pandas as pd

    if isinstance(duration, bool) or not isinstance(duration, numbers.Real) or not math.isfinite(duration) \
            or duration <= 0:
        raise OptionError(f"expected a recording time duration > 0 s, got {duration!r}")
    if isinstance(hz, bool) or not isinstance(hz, numbers.Real) or not math.isfinite(hz):
        raise OptionError(f"expected hz as a finite number, got {hz!r}")
    if hz != int(hz) or not 1 <= hz <= 200:
        raise OptionError(f"expected hz as a whole number in 1..200 Hz, got {hz!r}")
    hz = int(hz)
    if wire.io(wire.port.servo_stream) is None:
        raise DeviceError(f"{wire.name}: expected a servo-bus board behind the port (its stream frames read from the "
                          f"servos), got a board that sends FB lines")
    t_begin = wire.transact("PING", parse=_ping)
    wire.transact("STREAM", hz)
    try:
        t_end = wire.clock() + duration
        while wire.clock() < t_end:
            wire.pump(min(t_end - wire.clock(), 0.05))
    finally:
        wire.transact("STREAM", 0)
    rows = wire.io(wire.port.servo_stream)
    n = robot.n
    names = robot.joint_names
    cols = ["counter", "t_ms", *(f"tick{j}" for j in range(n)), *(f"current_{nm}" for nm in names)]
    df = pd.DataFrame(rows, columns=cols)
    df.insert(0, "t", df.pop("t_ms") / 1000.0)
    for j, (nm, lk) in enumerate(zip(names, robot.links)):
        df[f"q_{nm}"] = lk.bus.joint(df[f"tick{j}"].to_numpy(float))
    df = df[["t", "counter", *(f"tick{j}" for j in range(n)), *(f"q_{nm}" for nm in names),
             *(f"current_{nm}" for nm in names)]]
    expected = len(rows) if not rows else int(np.floor((rows[-1][1] - rows[0][1]) * hz / 1000.0 + 1e-6)) + 1
    df.attrs.update(expected=expected, lost=expected - len(rows), rejected=0, hz=hz, t_begin=t_begin)
    return df
