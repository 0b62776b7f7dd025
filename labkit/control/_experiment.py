"""Step tests on an arm: a joint stepped away and back while the feedback stream records it.

A step is the classic identification input, and a hobby servo receives one whenever its pulse width
jumps; the board's speed and acceleration limits (``LIMITS``, from the robot file) exist to prevent
exactly that. :func:`record_step` therefore lifts them on the board for the test and restores them after
(also on an error): it sends ``LIMITS`` of 0 (unchecked) with :meth:`labkit.arm.Arm.sync_calibration`
(``speed_limits=``), queues the two steps as protocol segments checked against those same limits
(:meth:`~labkit.arm.Arm.run_trajectory` with ``speed_limits=``, without waiting) and records
:meth:`~labkit.arm.Arm.stream` meanwhile, with the board's host-silence timeout off for the recording.
Nothing of the arm object changes: its robot (and so every later move's host-side check) stays the robot
file's; only the board's ``LIMITS`` and timeout are changed, and both are sent back after the recording, or,
when the step fails, after stopping the arm (a board still running the step's segments refuses ``LIMITS``).

The command the servo follows is a step slowed to the joint's ``max_velocity`` (the robot file's
servo speed, which a servo's motor cannot exceed; the virtual servo's rate limit is the same value):
:attr:`StepRecord.u` is that ramp, so :func:`fit_step_response` sees the input the servo really got.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labkit.control._identify import fit_step_response
from labkit.exceptions import OptionError, ShapeError
from labkit.validation import as_batch, as_number, readonly

__all__ = ["StepRecord", "record_step", "rate_limited_steps"]


@dataclass(frozen=True)
class StepRecord:
    """A joint's recorded response to a step away and back (:func:`record_step`).

    Attributes
    ----------
    joint : str
        Joint name.
    t : ndarray, shape (N,)
        Sample times [s of board time] from the first step.
    y : ndarray, shape (N,)
        Sensed joint value [rad, m] (potentiometer or present position).
    u : ndarray, shape (N,)
        Commanded joint value as the servo follows it [rad, m]: the steps, slowed to ``rate_limit``.
    amplitude : float
        Step size [rad, m].
    rate_limit : float or None
        Speed the command was slowed to [rad/s, m/s] (``None``: an ideal step).

    Examples
    --------
    >>> rec = StepRecord("j", np.arange(-4, 12) * 0.01, np.zeros(16), np.zeros(16), 0.1, None)
    >>> rec.to_dataframe().shape
    (16, 3)
    """

    joint: str
    t: np.ndarray
    y: np.ndarray
    u: np.ndarray
    amplitude: float
    rate_limit: float | None

    def __post_init__(self):
        for name in ("t", "y", "u"):
            object.__setattr__(self, name, readonly(np.asarray(getattr(self, name), dtype=float)))

    def fit(self, order=2):
        """:func:`fit_step_response` of this record (``u`` as the command).

        Parameters
        ----------
        order : {1, 2}

        Returns
        -------
        StepFit
        """
        return fit_step_response(self.t, self.y, u=self.u, order=order)

    def rest(self):
        """The sensed value before the first step [rad, m]: the mean of ``y`` over ``t < 0`` (``y[0]`` if none).

        Returns
        -------
        float
        """
        before = self.y[self.t < 0]
        return float(before.mean()) if before.size else float(self.y[0])

    def response(self, system, *, delay=0.0):
        """What a linear model of the joint predicts for this record: its output for the recorded command.

        The model starts at rest on :meth:`rest` (a static offset of the sensor, or a droop under load, is
        not the model's to explain) and is driven by ``u - u[0]``, ``delay`` seconds late.

        Parameters
        ----------
        system : control.LTI
            Command -> joint value, one input and one output (e.g. a servo's closed position loop).
        delay : float
            Dead time [s], >= 0 (the bus's or the board's latency, e.g. a :class:`StepFit`'s ``delay``).

        Returns
        -------
        y : ndarray, shape (N,)
            Predicted joint value at the record's times ``t`` [rad, m].

        Raises
        ------
        OptionError
            ``system`` is not a single-input single-output python-control system.

        Examples
        --------
        >>> import control
        >>> t = np.arange(-10, 60) * 0.01
        >>> rec = StepRecord("j", t, np.zeros(70), np.where(t >= 0, 0.1, 0.0), 0.1, None)
        >>> round(float(rec.response(control.tf([1], [0.05, 1]))[-1]), 4)
        0.1
        """
        import control

        if not isinstance(system, control.LTI) or system.ninputs != 1 or system.noutputs != 1:
            raise OptionError(f"expected a python-control system with one input and one output, got {system!r}")
        delay = as_number(delay, "delay", unit="s", minimum=0.0, error=OptionError)
        gaps = np.diff(self.t)[np.diff(self.t) > 0]  # a grid finer than the samples (and than 1 ms)
        step = min(1e-3, float(gaps.min()) / 2) if gaps.size else 1e-3
        grid = np.arange(self.t[0], self.t[-1] + step / 2, step)
        command = np.interp(grid - delay, self.t, self.u) - self.u[0]
        _, y = control.forced_response(system, T=grid - grid[0], U=command)
        return self.rest() + np.interp(self.t, grid, np.asarray(y, dtype=float))

    def overshoot(self, y=None):
        """How far the joint went past the first step's end value, in percent of the step.

        The end value is :meth:`rest` plus ``amplitude``; the window is from the step until the command
        starts back.

        Parameters
        ----------
        y : array_like, shape (N,), optional
            A response at the record's times (:meth:`response`); default the sensed ``y``.

        Returns
        -------
        float
            Largest excursion past the end value [% of the step]; negative: it stayed short by that much.

        Examples
        --------
        >>> t = np.arange(-2, 8) * 0.1
        >>> u = np.where((t >= 0) & (t < 0.5), 1.0, 0.0)
        >>> y = np.array([0, 0, 0, 0.8, 1.2, 1.05, 1.0, 0.3, 0.0, 0.0])
        >>> round(StepRecord("j", t, y, u, 1.0, None).overshoot(), 6)
        20.0
        """
        y = self.y if y is None else as_batch(y, (), "y (a response at the record's times)")
        if y.shape != self.t.shape:
            raise ShapeError(f"expected y with shape {self.t.shape} (one value per sample of the record), got {y.shape}")
        sign, size = math.copysign(1.0, self.amplitude), abs(self.amplitude)
        reached = sign * (self.u - self.u[0]) >= size * (1 - 1e-9)
        first = int(np.argmax(reached))
        left = np.flatnonzero(~reached[first:])
        window = slice(first, first + int(left[0]) if left.size else None)
        return float(100.0 * (sign * (y[window] - self.rest()) - size).max() / size)

    def to_dataframe(self):
        """The record as a table: ``t [s]``, ``command`` and ``sensed`` [rad].

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        return pd.DataFrame({"t": self.t, "command": self.u, "sensed": self.y})


def rate_limited_steps(t, start, edges, rate_limit):
    """A command that jumps to ``edges[k] = (time, value)`` in turn, moving at most ``rate_limit``.

    Parameters
    ----------
    t : array_like, shape (N,)
        Times [s], increasing.
    start : float
        Value before the first edge [rad, m].
    edges : sequence of (float, float)
        ``(time [s], new value)`` of each step, in time order.
    rate_limit : float or None
        Largest speed [rad/s, m/s]; ``None``: ideal steps.

    Returns
    -------
    u : ndarray, shape (N,)

    Examples
    --------
    >>> rate_limited_steps([0.0, 0.05, 0.1, 0.2], 0.0, [(0.0, 1.0)], 10.0).round(3).tolist()
    [0.0, 0.5, 1.0, 1.0]
    """
    t = as_batch(t, (), "t (times, s)")
    level = as_number(start, "start")
    u = np.full(t.shape, level)
    edges = as_batch(edges, (2,), "edges ((time [s], value) pairs)")
    if edges.ndim != 2:
        raise ShapeError(f"expected edges as a sequence of (time [s], value) pairs, got shape {edges.shape}")
    if rate_limit is not None:
        rate_limit = as_number(rate_limit, "rate_limit", positive=True)
    for k, (t_edge, value) in enumerate(edges):
        end = edges[k + 1][0] if k + 1 < len(edges) else np.inf
        span = (t >= t_edge) & (t < end)
        if rate_limit is None:
            u[span] = value
        else:  # the edges are far enough apart for each ramp to finish (record_step's hold)
            u[span] = level + np.clip((t[span] - t_edge) * rate_limit, 0.0, abs(value - level)) * np.sign(value - level)
        level = value
    return u


def record_step(arm, joint, amplitude, *, hold=0.3, hz=200):
    """Step one joint by ``amplitude`` and back, recording the feedback stream.

    The other joints hold where they are commanded; the joint starts from its commanded value.
    The sequence is: ``0.1 s`` at rest, the step, ``hold`` s, the step back, ``hold`` s. The board's
    speed limits and host-silence timeout are lifted during the test and restored after (see the
    module notes).

    Parameters
    ----------
    arm : labkit.arm.Arm
        The open arm (any board or bus labkit drives).
    joint : int or str
        Joint index or name.
    amplitude : float
        Step size [rad, m] (sign: direction); the stepped value must lie within the joint limits.
    hold : float
        Time after each step [s], 0.1..2 s (several settling times of the joint).
    hz : int
        Stream rate [Hz] (see :meth:`labkit.arm.Arm.stream`).

    Returns
    -------
    StepRecord

    Raises
    ------
    OptionError
        Unknown joint, ``amplitude`` zero or not finite, ``hold`` outside 0.1..2 s.
    JointLimitError
        The stepped joint value is outside the joint's limits (nothing moves).
    DeviceError
        The board rejected the segments or the link failed.
    """
    from labkit.motion import Trajectory

    robot = arm.robot
    j = _joint_index(robot, joint)
    amplitude = float(amplitude)
    if not (math.isfinite(amplitude) and amplitude != 0.0):
        raise OptionError(f"expected a finite, non-zero step amplitude [rad, m], got {amplitude!r}")
    if not (isinstance(hold, (int, float)) and 0.1 <= hold <= 2.0):
        raise OptionError(f"expected hold within 0.1..2 s, got {hold!r}")
    q0 = np.asarray(arm.commanded_joints(), dtype=float)
    q1 = q0.copy()
    q1[j] += amplitude
    robot.check_limits(q1)
    rest, jump = 0.1, 0.001  # a 1 ms segment: the next servo frame sees the new value (a step)
    times = [0.0, rest, rest + jump, rest + jump + hold, rest + 2 * jump + hold]
    Q = np.array([q0, q0, q1, q1, q0])
    steps = Trajectory(t=times, q=Q, qd=np.zeros_like(Q), qdd=np.zeros_like(Q))
    unchecked = ([0] * robot.n, [0] * robot.n)  # LIMITS 0: the board and the host check no speed
    timeout = arm.status().timeout
    try:
        arm.sync_calibration(speed_limits=unchecked)
        arm.set_host_timeout(0)
        t_start = arm.status().t
        arm.run_trajectory(steps, wait=False, min_duration=jump, speed_limits=unchecked)
        table = arm.stream(rest + 2 * (jump + hold), hz=hz)
    except BaseException as exc:
        try:  # a step cut short: stop its segments (a running board refuses LIMITS), then restore
            arm.stop()
            _restore(arm, timeout)
        except Exception as again:  # noqa: BLE001 - the first error is the one to raise
            exc.add_note(f"the board's speed limits and host-silence timeout could not be restored ({again}): "
                         f"reopen the arm before moving it")
        raise
    _restore(arm, timeout)
    t = table["t"].to_numpy(float) - t_start - rest
    y = table[f"q_{robot.joint_names[j]}"].to_numpy(float)
    rate = robot.links[j].max_velocity
    u = rate_limited_steps(t, q0[j], [(0.0, q1[j]), (hold + jump, q0[j])], rate)
    return StepRecord(joint=robot.joint_names[j], t=t, y=y, u=u, amplitude=amplitude, rate_limit=rate)


def _restore(arm, timeout):
    """The robot file's speed limits and the host-silence timeout ``timeout`` [s] back on the board."""
    arm.sync_calibration()
    arm.set_host_timeout(timeout)


def _joint_index(robot, joint):
    names = list(robot.joint_names)
    if isinstance(joint, str) and joint in names:
        return names.index(joint)
    if isinstance(joint, (int, np.integer)) and not isinstance(joint, bool) and 0 <= joint < robot.n:
        return int(joint)
    raise OptionError(f"expected a joint index 0..{robot.n - 1} or one of {names}, got {joint!r}")
