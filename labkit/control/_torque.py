"""Joint-space torque control simulated on the dynamics: computed torque and independent-joint PD.

Both controllers follow a desired joint trajectory ``q_d(t)`` (a :class:`labkit.motion.Trajectory`:
its time law where it has one, else its samples interpolated linearly) on torque-controlled joints, with the gains ``kp`` [1/s^2]
and ``kd`` [1/s] of the error dynamics ``e'' + kd e' + kp e = 0`` (``e = q_d - q``):

* **computed torque** (Craig, *Introduction to Robotics*, 10.5; Lynch & Park, *Modern Robotics*,
  11.4.1): ``tau = M^(q) (qdd_d + kd e' + kp e) + C^(q, qd) qd + g^(q)``, the model's
  :func:`labkit.dynamics.inverse_dynamics` at the commanded acceleration; with an exact model the
  error obeys the linear equation above at every pose;
* **PD** with the same gains: ``tau = m_j (kp e + kd e')`` per joint, ``m_j`` the diagonal of the
  model's mass matrix at the trajectory's start (independent-joint control, each joint seen as an
  inertia), plus the model's gravity torques when ``gravity_compensation``.

The controllers see only the **model** (a robot file, maybe wrong: a payload it does not know); the
plant that :func:`simulate_tracking` integrates is the **true** robot (:func:`labkit.dynamics.simulate`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from labkit.exceptions import ShapeError
from labkit.validation import as_batch, as_number, as_vector, check_robot, check_trajectory, readonly

__all__ = ["computed_torque_controller", "pd_controller", "TrackingResult", "simulate_tracking"]


def _desired(trajectory):
    """``t -> (q_d, qd_d, qdd_d)``: the trajectory's time law where it has one (exact), else linear
    interpolation of its samples (held at the ends)."""
    law = check_trajectory(trajectory, "trajectory").law
    if law is not None and law.shape == (np.shape(trajectory.q)[1],):
        def exact(time):
            time = min(max(time, law.t0), law.tf)
            return law.position(time), law.velocity(time), law.acceleration(time)

        return exact
    t = np.asarray(trajectory.t, dtype=float)
    Q, Qd, Qdd = (np.asarray(a, dtype=float) for a in (trajectory.q, trajectory.qd, trajectory.qdd))

    def at(time):
        return tuple(np.array([np.interp(time, t, A[:, j]) for j in range(A.shape[1])]) for A in (Q, Qd, Qdd))

    return at


def _gains(model, kp, kd):
    """``kp, kd`` as (n,) arrays (a scalar for every joint); a wrong shape is a ShapeError."""
    check_robot(model, "model")

    def gain(value, name):
        value = as_batch(value, (), name)
        return as_vector(np.full(model.n, float(value)) if value.ndim == 0 else value, model.n, name)

    return gain(kp, "kp (1/s^2)"), gain(kd, "kd (1/s)")


def computed_torque_controller(model, trajectory, kp, kd, *, gravity=None, friction=True):
    """A computed-torque controller ``(t, q, qd) -> tau`` following ``trajectory`` (module notes).

    Parameters
    ----------
    model : Robot
        The controller's model of the arm (with inertial parameters).
    trajectory : labkit.motion.Trajectory
        Desired joint motion (``q``, ``qd``, ``qdd`` sampled at ``t``).
    kp : float or array_like, shape (n,)
        Position gain [1/s^2] (``wn^2`` of the error dynamics).
    kd : float or array_like, shape (n,)
        Velocity gain [1/s] (``2 zeta wn``).
    gravity : array_like, shape (3,), optional
        Gravity the model assumes [m/s^2] (default: the robot's).
    friction : bool
        Compensate the model's motor friction (see :func:`labkit.dynamics.inverse_dynamics`).

    Returns
    -------
    callable
        ``tau = controller(t, q, qd)`` [N m, N], shape (n,), for :func:`labkit.dynamics.simulate`.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> from labkit.motion import joint_trajectory
    >>> puma = Robot.load("puma560")
    >>> traj = joint_trajectory(puma, np.zeros(6), np.full(6, 0.2), 1.0)
    >>> ctl = computed_torque_controller(puma, traj, 100.0, 20.0)
    >>> ctl(0.0, np.zeros(6), np.zeros(6)).shape
    (6,)
    """
    from labkit.dynamics import inverse_dynamics

    kp, kd = _gains(model, kp, kd)
    desired = _desired(trajectory)

    def controller(t, q, qd):
        q_d, qd_d, qdd_d = desired(t)
        qdd_ref = qdd_d + kd * (qd_d - qd) + kp * (q_d - q)
        return inverse_dynamics(model, q, qd, qdd_ref, gravity=gravity, friction=friction)

    q_start, qd_start, _ = desired(float(trajectory.t[0]))
    controller(float(trajectory.t[0]), q_start, qd_start)  # bad gravity or a model without inertia: raise now
    return controller


def pd_controller(model, trajectory, kp, kd, *, gravity_compensation=False, gravity=None):
    """An independent-joint PD controller ``(t, q, qd) -> tau`` with the gains of computed torque.

    Parameters
    ----------
    model : Robot
        The controller's model (its mass-matrix diagonal at the trajectory's start scales the gains,
        its gravity torques compensate gravity when asked).
    trajectory : labkit.motion.Trajectory
        Desired joint motion.
    kp, kd : float or array_like, shape (n,)
        Gains [1/s^2], [1/s] (see :func:`computed_torque_controller`).
    gravity_compensation : bool
        Add the model's gravity torques ``g^(q)``.
    gravity : array_like, shape (3,), optional
        Gravity the model assumes [m/s^2].

    Returns
    -------
    callable
        ``tau = controller(t, q, qd)`` [N m, N], shape (n,).

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> from labkit.motion import joint_trajectory
    >>> puma = Robot.load("puma560")
    >>> traj = joint_trajectory(puma, np.zeros(6), np.full(6, 0.2), 1.0)
    >>> pd = pd_controller(puma, traj, 100.0, 20.0)
    >>> bool(np.allclose(pd(0.0, np.zeros(6), np.zeros(6)), 0.0))
    True
    """
    from labkit.dynamics import gravity_torques, mass_matrix

    kp, kd = _gains(model, kp, kd)
    desired = _desired(trajectory)
    inertia = np.diagonal(mass_matrix(model, np.asarray(trajectory.q[0], dtype=float))).copy()

    def controller(t, q, qd):
        q_d, qd_d, _ = desired(t)
        tau = inertia * (kp * (q_d - q) + kd * (qd_d - qd))
        return tau + gravity_torques(model, q, gravity=gravity) if gravity_compensation else tau

    q_start, qd_start, _ = desired(float(trajectory.t[0]))
    controller(float(trajectory.t[0]), q_start, qd_start)  # bad gravity: raise now, not inside the simulation
    return controller


@dataclass(frozen=True)
class TrackingResult:
    """A simulated tracking run (:func:`simulate_tracking`).

    Attributes
    ----------
    t : ndarray, shape (m,)
        Sample times [s].
    q, q_desired : ndarray, shape (m, n)
        Joint values reached and desired [rad, m].
    tau : ndarray, shape (m, n)
        Joint torques applied [N m, N].
    joint_names : tuple of str
    """

    t: np.ndarray
    q: np.ndarray
    q_desired: np.ndarray
    tau: np.ndarray
    joint_names: tuple

    @property
    def error(self):
        """``q_desired - q``, shape (m, n) [rad, m]."""
        return self.q_desired - self.q

    @property
    def rms_error(self):
        """RMS tracking error over the run, all joints together [rad, m]."""
        return float(np.sqrt(np.mean(self.error ** 2)))

    @property
    def max_error(self):
        """Largest absolute joint error over the run [rad, m]."""
        return float(np.max(np.abs(self.error)))

    def to_dataframe(self):
        """Per joint: RMS and largest tracking error [rad] and largest torque [N m].

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        e = self.error
        return pd.DataFrame({"joint": list(self.joint_names),
                             "rms error [rad]": np.sqrt(np.mean(e ** 2, axis=0)),
                             "max error [rad]": np.max(np.abs(e), axis=0),
                             "max torque [N m]": np.max(np.abs(self.tau), axis=0)})


def simulate_tracking(robot, trajectory, controller, *, dt=0.005, gravity=None, friction=True, solver="RK45",
                      rtol=1e-6, atol=1e-8):
    """Simulate the true ``robot`` under ``controller`` from the trajectory's first sample, at rest.

    Parameters
    ----------
    robot : Robot
        The plant (true inertial parameters, e.g. ``model.with_payload(...)``).
    trajectory : labkit.motion.Trajectory
        Desired joint motion (its start is the initial state; its end, the end of the run).
    controller : callable
        ``tau = controller(t, q, qd)`` (:func:`computed_torque_controller`, :func:`pd_controller`).
    dt : float
        Output sample step [s].
    gravity : array_like, shape (3,), optional
        True gravity [m/s^2].
    friction : bool
        Include the motors' friction in the plant.
    solver, rtol, atol
        See :func:`labkit.dynamics.simulate`.

    Returns
    -------
    TrackingResult

    Raises
    ------
    ShapeError
        The trajectory's joint count is not the robot's, or ``dt`` not > 0.
    """
    from labkit.dynamics import simulate

    check_robot(robot)
    desired = _desired(trajectory)
    if not callable(controller):
        raise ShapeError(f"expected controller as a function tau(t, q, qd), got {controller!r}")
    dt = as_number(dt, "dt", unit="s", positive=True)
    Q = np.asarray(trajectory.q, dtype=float)
    if Q.ndim != 2 or Q.shape[1] != robot.n:
        raise ShapeError(f"expected a trajectory of {robot.n} joints, got q with shape {Q.shape}")
    t0, tf = float(trajectory.t[0]), float(trajectory.t[-1])
    t = np.linspace(t0, tf, max(2, int(round((tf - t0) / dt)) + 1))
    run = simulate(robot, Q[0], np.zeros(robot.n), t, torque=controller, gravity=gravity, friction=friction,
                   solver=solver, rtol=rtol, atol=atol)
    q_d = np.array([desired(tk)[0] for tk in t])
    return TrackingResult(readonly(t), readonly(np.asarray(run.q)), readonly(q_d), readonly(np.asarray(run.tau)),
                          tuple(robot.joint_names))
