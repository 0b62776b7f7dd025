"""Feedback stream of the host link: which ``FB`` frames to trust, and the table of a recording.

Every frame carries a CRC-32; on top of it (a board that writes a wrong
value seals it with a good CRC), a frame counts only when a neighbouring frame
confirms it: consecutive
counters, board times that fit the stream rate, and joint readings that
cannot have moved faster than the joints can. :class:`FrameFilter` is the
sink :class:`labkit.arm.Arm` sets on its wire while it records;
:func:`frame_table` turns what was accepted into a pandas table with the
losses accounted for.
"""

from __future__ import annotations

import math
import time

import numpy as np

from labkit.exceptions import OptionError, ProtocolError
from labkit.arm._protocol import board_int
from labkit.arm._actuator import joint_sensor
from labkit.arm.link._inputs import finite, whole
from labkit.arm.link._replies import parse_ping
from labkit.arm.bus import record_bus_stream

__all__ = []


def adc_slew(robot):
    """Largest feedback change per second of each joint [counts/s] (joint speed limit x ADC gain, 1.5x margin).

    Parameters
    ----------
    robot : labkit.robot.Robot

    Returns
    -------
    ndarray, shape (n,)
        ``inf`` for joints without a servo.
    """
    return np.array([
        1.5 * (math.radians(600) if lk.max_velocity is None else lk.max_velocity)
        * abs(float(lk.servo.adc_from_joint(1.0) - lk.servo.adc_from_joint(0.0))) if lk.servo else np.inf
        for lk in robot.links])


def joints_from_counts(robot, counts):
    """Joint values from feedback counts: each joint's servo pot, or an ideal actuator's encoder over its limits.

    Parameters
    ----------
    robot : labkit.robot.Robot
    counts : array_like, shape (..., n)
        Feedback ADC counts per joint (may be fractional, e.g. averages).

    Returns
    -------
    ndarray, shape (..., n)
        Joint values [rad | m].
    """
    counts = np.asarray(counts, dtype=float)
    return np.stack([joint_sensor(robot, j).joint_from_adc(counts[..., j]) for j in range(robot.n)], axis=-1)


#: a settled joint is within this of its command, before the feedback's own resolution widens it [rad | m]
SETTLE_REVOLUTE = math.radians(1.0)
SETTLE_PRISMATIC = 1e-3


def settle_tolerance(robot, counts=3.0):
    """How close each joint's feedback must come to a command to count as settled [rad | m].

    1 deg for a revolute joint and 1 mm for a prismatic one, widened to ``counts`` feedback counts where one
    count is coarser (an ideal actuator's 10-bit encoder over a long axis, an RC linear servo's pot; a servo
    bus's present position is read in ticks, finer than both).

    Parameters
    ----------
    robot : labkit.robot.Robot
    counts : float
        Feedback counts the reading may be off by (noise and quantisation).

    Returns
    -------
    ndarray, shape (n,)
        Tolerance per joint [rad | m].

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> settle_tolerance(Robot.load("gantry_ppp")).round(4)   # 10-bit encoders: 3 counts of a short axis < 1 mm
    array([0.001, 0.001, 0.001])
    >>> settle_tolerance(Robot.load("arduino_arm_3dof")).round(4)   # hobby servos: 1 deg [rad]
    array([0.0175, 0.0175, 0.0175])
    """
    base = np.where(robot.is_revolute, SETTLE_REVOLUTE, SETTLE_PRISMATIC)
    if robot.bus is not None:
        return base
    step = np.array([abs(float(joint_sensor(robot, j).joint_from_adc(counts) - joint_sensor(robot, j).joint_from_adc(0.0)))
                     for j in range(robot.n)])
    return np.maximum(base, step)


class FrameFilter:
    """Accepts a feedback frame only when a neighbouring frame confirms it.

    Parameters
    ----------
    robot : labkit.robot.Robot
        Joint count and speed limits.
    hz : int
        Stream rate [Hz].
    stats : LinkStats
        Counters to update (``frames``, ``rejected_frames``).

    Attributes
    ----------
    rows : list of tuple
        Accepted frames ``(host time [s since epoch], counter, t_ms, adc..., pot)``.
    pending : tuple or None
        The last frame, still waiting for confirmation.
    """

    def __init__(self, robot, hz, stats):
        self.hz = int(hz)
        self.joints = robot.n
        self.stats = stats
        self.slew = adc_slew(robot)
        self.last = None
        self.pending = None
        self.rows = []

    def _consistent(self, a, b):
        """Can frame ``b`` follow frame ``a`` (counters, board times, joint speeds)?"""
        gap = (b[0] - a[0]) % 65536
        if not 1 <= gap < 65536 // 2:
            return False
        # the firmware stamps a frame when it sends it: a few ms of jitter, never drift
        if abs((b[1] - a[1]) - gap * 1000.0 / self.hz) > 2.0 + 250.0 / self.hz:
            return False
        # joints cannot jump: a wrong digit changes a value a lot
        J = self.joints
        step = np.abs(np.array(b[2:2 + J]) - np.array(a[2:2 + J]))
        return bool(np.all(step <= self.slew * gap / self.hz + 12))

    def add(self, tokens):
        """Take one ``FB`` line: keep it once a neighbour confirms it, count it if it is damaged.

        Parameters
        ----------
        tokens : list of str
            ``["FB", counter, t_ms, adc..., pot]``.
        """
        try:
            vals = tuple(board_int(v) for v in tokens[1:])
        except ProtocolError:
            vals = ()
        J = self.joints
        if not (len(vals) == J + 3 and 0 <= vals[0] <= 65535 and all(0 <= a <= 1023 for a in vals[2:])):
            self.stats.rejected_frames += 1
            return
        accept = []
        anchor, pending = self.last, self.pending
        if anchor is not None and self._consistent(anchor, vals):
            accept = [vals]
        elif pending is not None and self._consistent(pending, vals):
            accept = [pending, vals]  # two frames that agree: (re-)anchor on them
        self.pending = None if accept else vals
        if pending is not None and not accept:
            self.stats.rejected_frames += 1
        for v in accept:
            self.rows.append((time.time(), *v))
            self.last = v
            self.stats.frames += 1


def record_stream(robot, wire, duration, hz):
    """Record the feedback stream for ``duration`` s of board time (see :meth:`labkit.arm.Arm.stream`).

    Parameters
    ----------
    robot : labkit.robot.Robot
        Joint count, speed limits and servo calibrations.
    wire : Wire
        The link's wire object; its :attr:`~Wire.frames` sink is set while recording.
    duration : float
        Recording time [s of board time].
    hz : int
        Frame rate [Hz], a whole number 1..200.

    Returns
    -------
    pandas.DataFrame
        The table of :func:`frame_table`.

    Raises
    ------
    OptionError
        ``duration`` not > 0 s, or ``hz`` not a whole number in 1..200.
    """
    if robot.bus is not None:  # a servo bus: the servos' positions and currents, one sync read per frame
        return record_bus_stream(robot, wire, duration, hz)
    duration = finite("duration", duration, unit="s")
    if duration <= 0:
        raise OptionError(f"expected a recording time duration > 0 s, got {duration:g}")
    hz = whole("hz", hz, lo=1, hi=200, unit="Hz")
    stats = wire.stats
    rejected0 = stats.rejected_frames + stats.bad_lines
    t_begin = wire.transact("PING", parse=parse_ping)
    frames = wire.frames = FrameFilter(robot, hz, stats)
    try:
        wire.transact("STREAM", hz)
        t_end = wire.clock() + duration
        while wire.clock() < t_end:
            wire.pump(min(t_end - wire.clock(), 0.05))
        t_stop = wire.transact("PING", parse=parse_ping)  # every frame stamped before this arrived before its reply
        wire.transact("STREAM", 0)
    finally:
        wire.frames = None
    return frame_table(robot, frames, t_begin, t_stop, rejected0)


def frame_table(robot, frames, t_begin, t_stop, rejected0):
    """The recording of a :class:`FrameFilter` as a table, with losses counted.

    Parameters
    ----------
    robot : labkit.robot.Robot
        Servo calibrations turning counts into joint values.
    frames : FrameFilter
        The filter after the stream was switched off.
    t_begin, t_stop : float
        Board times [s] just before the stream was switched on and after the last frame.
    rejected0 : int
        ``stats.rejected_frames + stats.bad_lines`` before the recording.

    Returns
    -------
    pandas.DataFrame
        See :meth:`labkit.arm.Arm.stream`.
    """
    import pandas as pd

    hz, stats = frames.hz, frames.stats
    t_stop_ms = round(t_stop * 1000)
    rows = [r for r in frames.rows if r[2] < t_stop_ms]
    # frames the board sent before t_stop: counter 0 at t0, one every 1/hz
    t0_ms = rows[0][2] - rows[0][1] * 1000.0 / hz if rows else t_begin * 1000
    expected = max(0, math.ceil((t_stop_ms - t0_ms) * hz / 1000.0 - 1e-6))
    lost = expected - len(rows)
    stats.lost_frames += lost
    if frames.pending is not None:
        stats.rejected_frames += 1  # never confirmed
    J = robot.n
    cols = ["received", "counter", "t_ms", *(f"adc{j}" for j in range(J)), "pot"]
    df = pd.DataFrame(rows, columns=cols)
    df["received"] = pd.to_datetime(df["received"], unit="s", utc=True)
    df.insert(0, "t", df.pop("t_ms") / 1000.0)
    q = joints_from_counts(robot, df[[f"adc{j}" for j in range(J)]].to_numpy(float))
    for j, name in enumerate(robot.joint_names):
        df[f"q_{name}"] = q[:, j]
    df.attrs.update(lost=lost, expected=expected, t_stop=t_stop_ms / 1000.0,
                    rejected=stats.rejected_frames + stats.bad_lines - rejected0, hz=hz)
    return df
