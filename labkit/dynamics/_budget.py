"""A servo torque budget: can the servos hold (or drive) this pose with this payload, and with what margin."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from labkit.dynamics._rne import gravity_torques, inverse_dynamics
from labkit.exceptions import RobotError, ShapeError, TorqueWarning
from labkit.validation import as_batch, as_number, check_robot, check_trajectory, readonly

__all__ = ["TorqueBudget", "torque_budget", "stall_torques", "torques_from_current", "check_torque_budget"]


def stall_torques(robot):
    """Each joint's servo stall torque from the robot file (``servo`` or ``bus`` table).

    Parameters
    ----------
    robot : Robot

    Returns
    -------
    ndarray, shape (n,)
        [N m].

    Raises
    ------
    RobotError
        A joint whose servo has no ``stall_torque`` (named).

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> stall_torques(Robot.load("arduino_arm_3dof")).tolist()
    [0.92, 0.92, 0.92]
    """
    out = []
    for i, lk in enumerate(check_robot(robot).links, start=1):
        servo = lk.servo or lk.bus
        if servo is None or servo.stall_torque is None:
            raise RobotError(f"robot {robot.name!r}: joint {i} ({robot.joint_names[i - 1]}): expected a servo with "
                             f"stall_torque [N m] in its servo or bus table, got none", f"joint[{i}].stall_torque")
        out.append(servo.stall_torque)
    return np.array(out)


def torques_from_current(robot, current):
    """Joint torques that bus servos' present currents stand for: ``direction * torque_constant * current``.

    The torque constant is each bus servo's ``torque_constant`` in the robot file (stall torque
    over stall current from its datasheet); the direction turns the servo's sense into the
    joint's.

    Parameters
    ----------
    robot : Robot
        An arm on a servo bus with ``torque_constant`` in every joint's ``bus`` table.
    current : array_like, shape (..., n)
        Present currents [A] (:meth:`labkit.arm.Arm.read_load`).

    Returns
    -------
    ndarray, shape (..., n)
        Joint torques [N m].

    Raises
    ------
    RobotError
        A joint that is not a bus servo or whose bus table has no ``torque_constant`` (named).
    ShapeError
        ``current`` is not of shape (..., n).

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> torques_from_current(Robot.load("openmanipulator_x"), [0.0, -0.5, 0.2, 0.1]).round(3).tolist()
    [0.0, -0.89, 0.356, 0.178]
    """
    gains = []
    for i, lk in enumerate(check_robot(robot).links, start=1):
        if lk.bus is None or lk.bus.torque_constant is None:
            raise RobotError(f"robot {robot.name!r}: joint {i} ({robot.joint_names[i - 1]}): expected a bus servo with "
                             f"torque_constant [N m/A] in its bus table, got none", f"joint[{i}].torque_constant")
        gains.append(lk.bus.direction * lk.bus.torque_constant)
    return as_batch(current, (robot.n,), "current (present currents, A)") * np.array(gains)


@dataclass(frozen=True)
class TorqueBudget:
    """Joint torques set against the servos' stall torques.

    Attributes
    ----------
    torque : ndarray, shape (..., n)
        Torque each joint needs [N m].
    stall : ndarray, shape (n,)
        Each servo's stall torque [N m].
    load : ndarray, shape (..., n)
        ``|torque| / stall`` [1]: 1 is a stalled servo.
    margin : ndarray, shape (...)
        ``1 / max(load)`` over the joints: how many times the worst joint's need the servo gives
        (``inf`` where nothing is needed).
    worst_joint : ndarray of int, shape (...)
        0-based index of the most loaded joint.
    """

    torque: np.ndarray
    stall: np.ndarray
    load: np.ndarray
    margin: np.ndarray
    worst_joint: np.ndarray

    @property
    def ok(self):
        """Whether every servo gives more than the pose needs [bool, shape (...)]."""
        return self.margin > 1.0


def torque_budget(robot, q, *, qd=None, qdd=None, payload=0.0, payload_com=(0.0, 0.0, 0.0), gravity=None):
    """Can the servos hold ``q`` (or drive ``q, qd, qdd``) with a payload, and with what margin?

    Over a pose or a map of poses (any batch shape). Holding is ``gravity_torques``; with
    ``qd``/``qdd`` it is the full ``inverse_dynamics`` (friction included).

    Parameters
    ----------
    robot : Robot
        With inertial parameters and ``stall_torque`` on every servo.
    q : array_like, shape (..., n)
        Joint values [rad, m].
    qd, qdd : array_like, shape (..., n), optional
        Joint velocities and accelerations of a motion [rad/s, rad/s^2]; default: holding still.
    payload : float
        Mass carried at the tool [kg].
    payload_com : array_like, shape (3,)
        Its centre of mass in the tool frame [m].
    gravity : array_like, shape (3,), optional
        Gravity in world coordinates [m/s^2]; default 9.81 along ``-robot.up``.

    Returns
    -------
    TorqueBudget

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> budget = torque_budget(arm, [0.0, 0.0, 0.0], payload=0.1)   # arm stretched out horizontally
    >>> bool(budget.ok), int(budget.worst_joint), round(float(budget.margin), 1)
    (True, 1, 2.4)
    """
    stall = stall_torques(robot)
    payload = as_number(payload, "payload", unit="kg")
    held = robot.with_payload(payload, payload_com) if payload else robot
    if qd is None and qdd is None:
        tau = gravity_torques(held, q, gravity=gravity)
    else:
        zero = np.zeros(robot.n)
        tau = inverse_dynamics(held, q, zero if qd is None else qd, zero if qdd is None else qdd, gravity=gravity)
    load = np.abs(tau) / stall
    worst = load.max(axis=-1)
    with np.errstate(divide="ignore"):
        margin = np.where(worst > 0, 1.0 / np.where(worst > 0, worst, 1.0), np.inf)
    return TorqueBudget(readonly(tau), readonly(stall), readonly(load), readonly(margin),
                        readonly(load.argmax(axis=-1)).astype(int))


def check_torque_budget(robot, trajectory, *, payload=0.0, payload_com=(0.0, 0.0, 0.0), gravity=None):
    """The torque budget of a motion plan, with a :class:`~labkit.exceptions.TorqueWarning` where it overdraws.

    Call it before the plan goes to the arm: every sample's inverse dynamics (holding,
    accelerating, friction) against the servos' stall torques. A plan that asks any joint for
    more than its servo gives is warned about (which joint, when, how much), not refused: a
    servo at its stall torque lags and heats rather than breaks, and the arm may carry less
    than ``payload``.

    Parameters
    ----------
    robot : Robot
        With inertial parameters and ``stall_torque`` on every servo.
    trajectory : Trajectory
        A motion plan with samples ``t`` (m,) [s] and ``q``, ``qd``, ``qdd`` (m, n)
        (:func:`labkit.motion.joint_trajectory`, :func:`labkit.motion.cartesian_trajectory`).
    payload : float
        Mass carried at the tool [kg].
    payload_com : array_like, shape (3,)
        Its centre of mass in the tool frame [m].
    gravity : array_like, shape (3,), optional
        Gravity in world coordinates [m/s^2]; default 9.81 along ``-robot.up``.

    Returns
    -------
    TorqueBudget
        Per sample: ``torque`` (m, n), ``margin`` (m,), ...

    Warns
    -----
    TorqueWarning
        Some sample needs more than a servo's stall torque.

    Raises
    ------
    RobotError
        The robot file has no inertias, or a servo without ``stall_torque``.
    ShapeError
        ``trajectory`` has no ``q``, ``qd``, ``qdd`` samples of shape (m, n).

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> from labkit.motion import joint_trajectory
    >>> arm = Robot.load("arduino_arm_3dof")
    >>> plan = joint_trajectory(arm, [1.5, 1.0, 1.0], [1.5, 0.2, 0.6], 1.0, law="quintic")
    >>> round(float(check_torque_budget(arm, plan).margin.min()), 1)   # 8 times what the plan needs
    8.0
    """
    import warnings

    check_robot(robot)
    check_trajectory(trajectory, "trajectory", error=ShapeError)
    t, q, qd, qdd = (np.asarray(getattr(trajectory, k), dtype=float) for k in ("t", "q", "qd", "qdd"))
    if q.ndim != 2 or q.shape[1] != robot.n or qd.shape != q.shape or qdd.shape != q.shape or t.shape != q.shape[:1]:
        raise ShapeError(f"expected a trajectory of {robot.n} joints (t (m,), q, qd, qdd (m, {robot.n})), got "
                         f"t {t.shape}, q {q.shape}, qd {qd.shape}, qdd {qdd.shape}")
    budget = torque_budget(robot, q, qd=qd, qdd=qdd, payload=payload, payload_com=payload_com, gravity=gravity)
    if not np.all(budget.ok):
        k = int(np.argmin(budget.margin))
        j = int(budget.worst_joint[k])
        over = int(np.count_nonzero(~budget.ok))
        warnings.warn(f"robot {robot.name!r}: the motion plan asks {robot.joint_names[j]} for "
                      f"{abs(budget.torque[k, j]):.3g} N m at t = {t[k]:.3g} s, above its servo's stall torque of "
                      f"{budget.stall[j]:.3g} N m ({over} of {len(t)} samples over; payload {payload:g} kg): slow the "
                      f"move down, lighten the load or choose poses nearer the support", TorqueWarning, stacklevel=2)
    return budget
