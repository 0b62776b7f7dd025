"""Forward dynamics and simulation: accelerations from torques, integrated with scipy's ``solve_ivp``."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from labkit.dynamics._model import body, by_chunks, default_gravity, geometry, joint_arrays
from labkit.dynamics._rne import composite_mass, inverse
from labkit.exceptions import DynamicsError, OptionError, ShapeError
from labkit.validation import as_batch, as_number, readonly

__all__ = ["forward_dynamics", "Simulation", "simulate", "INTEGRATORS"]

#: the integrators of scipy.integrate.solve_ivp that simulate accepts
INTEGRATORS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
#: a Cholesky pivot below this fraction of the largest diagonal entry of M counts as singular
_SINGULAR = 1e-12


def forward_dynamics(robot, q, qd, tau, *, gravity=None, friction=True):
    """Joint accelerations under joint torques: ``M(q) qdd = tau - C(q, qd) qd - g(q) - friction(qd)``.

    Parameters
    ----------
    robot : Robot
        With inertial parameters.
    q, qd : array_like, shape (..., n)
        Joint values [rad, m] and velocities [rad/s, m/s].
    tau : array_like, shape (..., n)
        Joint torques [N m] and forces [N] applied by the drives.
    gravity : array_like, shape (3,), optional
        Gravity in world coordinates [m/s^2]; default 9.81 along ``-robot.up``.
    friction : bool
        Subtract the motors' viscous and Coulomb friction.

    Returns
    -------
    qdd : ndarray, shape (..., n)
        Joint accelerations [rad/s^2, m/s^2].

    Raises
    ------
    DynamicsError
        The mass matrix is singular (a joint moves no mass and has no rotor inertia).

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> from labkit.dynamics import gravity_torques
    >>> puma, q = Robot.load("puma560"), np.array([0, 0.5, 0, 0, 0, 0])
    >>> bool(np.allclose(forward_dynamics(puma, q, np.zeros(6), gravity_torques(puma, q)), 0))
    True
    """
    parts = body(robot)
    q, qd, tau = joint_arrays(robot, q=q, qd=qd, tau=tau)
    g = default_gravity(robot, gravity)
    return by_chunks(lambda q, qd, tau: _accelerations(robot, parts, q, qd, tau, g, friction), (q, qd, tau),
                     (robot.n,))


def _accelerations(robot, parts, q, qd, tau, gravity, friction):
    """:func:`forward_dynamics` on checked arrays (the simulation's right-hand side)."""
    geo = geometry(robot, q, parts)
    bias = inverse(parts, geo, qd, np.zeros(robot.n), gravity, friction)
    M = composite_mass(parts, geo)
    _check_definite(robot, M, q)
    return np.linalg.solve(M, (tau - bias)[..., None])[..., 0]


def _check_definite(robot, M, q):
    """A DynamicsError unless every M is numerically positive definite (Cholesky pivots above rounding)."""
    scale = np.diagonal(M, axis1=-2, axis2=-1).max(axis=-1)
    try:
        pivots = np.diagonal(np.linalg.cholesky(M), axis1=-2, axis2=-1) ** 2
        bad = pivots.min(axis=-1) <= _SINGULAR * scale
    except np.linalg.LinAlgError:
        bad = np.array([np.linalg.eigvalsh(m)[0] <= _SINGULAR * s for m, s in
                        zip(M.reshape(-1, *M.shape[-2:]), scale.reshape(-1))]).reshape(scale.shape)
    if np.any(bad):
        raise DynamicsError(f"robot {robot.name!r}: expected a positive definite mass matrix, got a singular one "
                            f"(a joint that moves no mass and has no rotor inertia) at q = "
                            f"{np.round(q.reshape(-1, q.shape[-1])[int(np.argmax(bad.reshape(-1)))], 4).tolist()} rad")


@dataclass(frozen=True)
class Simulation:
    """A simulated motion, sampled at the requested times.

    Attributes
    ----------
    t : ndarray, shape (m,)
        Sample times [s].
    q, qd, qdd : ndarray, shape (m, ..., n)
        Joint values [rad, m], velocities and accelerations.
    tau : ndarray, shape (m, ..., n)
        Joint torques the drives applied [N m, N].
    evaluations : int
        Right-hand-side evaluations the integrator used.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    evaluations: int

    def to_dataframe(self):
        """One row per sample (a single simulated arm): time, joint values, velocities, torques.

        Returns
        -------
        pandas.DataFrame
            Columns ``t [s]``, ``q1 .. qn``, ``qd1 .. qdn``, ``tau1 .. taun`` (SI units, rad).

        Raises
        ------
        ShapeError
            The simulation holds a batch of arms (``q`` is not (m, n)).
        """
        import pandas as pd

        if self.q.ndim != 2:
            raise ShapeError(f"to_dataframe needs one simulated arm (q of shape (m, n)), got {self.q.shape}")
        n = self.q.shape[-1]
        cols = {"t [s]": self.t}
        for name, arr in (("q", self.q), ("qd", self.qd), ("tau", self.tau)):
            cols.update({f"{name}{j + 1}": arr[:, j] for j in range(n)})
        return pd.DataFrame(cols)


def _torque_function(robot, torque, shape):
    """``torque`` as a function ``(t, q, qd) -> tau`` of shape ``shape`` (the state's)."""
    if torque is None:
        zero = np.zeros(shape)
        return lambda t, q, qd: zero

    def fitted(tau, what):
        tau = as_batch(tau, (robot.n,), what)
        try:
            return np.broadcast_to(tau, shape)
        except ValueError:
            raise ShapeError(f"expected {what} with shape {shape}, got {tau.shape}") from None

    if callable(torque):
        return lambda t, q, qd: fitted(torque(t, q, qd), "torque(t, q, qd) (joint torques, N m)")
    constant = fitted(torque, "torque (joint torques, N m)")
    return lambda t, q, qd: constant


def simulate(robot, q0, qd0, t, *, torque=None, gravity=None, friction=True, solver="DOP853", rtol=1e-10,
             atol=1e-10):
    """Integrate the forward dynamics from ``q0, qd0`` under a torque or a controller.

    Parameters
    ----------
    robot : Robot
        With inertial parameters.
    q0, qd0 : array_like, shape (..., n)
        Initial joint values [rad, m] and velocities [rad/s, m/s]; a batch simulates
        several arms at once.
    t : array_like, shape (m,)
        Sample times [s], increasing, at least two; the motion starts at ``t[0]``.
    torque : array_like of shape (..., n), callable, or None
        Constant joint torques [N m, N], or a controller ``torque(t, q, qd) -> tau``
        called with the time [s] and the state of shape (..., n); None: no drive torque
        (a free swing).
    gravity : array_like, shape (3,), optional
        Gravity in world coordinates [m/s^2]; default 9.81 along ``-robot.up``.
    friction : bool
        Include the motors' viscous and Coulomb friction.
    solver : {"RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA"}
        The :func:`scipy.integrate.solve_ivp` integrator.
    rtol, atol : float
        The integrator's relative and absolute tolerances.

    Returns
    -------
    Simulation

    Raises
    ------
    OptionError
        An unknown ``solver``.
    ShapeError
        Bad ``t`` (not increasing, fewer than two samples) or state shapes.
    DynamicsError
        The integrator failed (its message is given) or the mass matrix is singular.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> from labkit.dynamics import kinetic_energy, potential_energy
    >>> puma = Robot.load("puma560")
    >>> run = simulate(puma, [0, 0.5, 0, 0, 0, 0], np.zeros(6), np.linspace(0, 0.2, 5), friction=False)
    >>> E = kinetic_energy(puma, run.q, run.qd) + potential_energy(puma, run.q)
    >>> bool(np.ptp(E) < 1e-6)
    True
    """
    from scipy.integrate import solve_ivp

    if solver not in INTEGRATORS:
        raise OptionError(f"expected solver one of {', '.join(INTEGRATORS)}, got {solver!r}")
    q0, qd0 = joint_arrays(robot, q0=q0, qd0=qd0)
    times = as_batch(t, (), "t (sample times, s)")
    if times.ndim != 1 or times.size < 2 or not np.all(np.diff(times) > 0):
        raise ShapeError(f"expected t as increasing sample times of shape (m,) with m >= 2, got {t!r}")
    rtol, atol = (as_number(v, name, positive=True) for v, name in ((rtol, "rtol"), (atol, "atol")))
    shape = q0.shape
    drive = _torque_function(robot, torque, shape)
    parts, g = body(robot), default_gravity(robot, gravity)

    def rhs(time, y):
        q, qd = y[:y.size // 2].reshape(shape), y[y.size // 2:].reshape(shape)
        qdd = _accelerations(robot, parts, q, qd, drive(time, q, qd), g, friction)
        return np.concatenate([qd.reshape(-1), qdd.reshape(-1)])

    y0 = np.concatenate([q0.reshape(-1), qd0.reshape(-1)])
    sol = solve_ivp(rhs, (times[0], times[-1]), y0, method=solver, t_eval=times, rtol=rtol, atol=atol)
    if not sol.success:
        raise DynamicsError(f"robot {robot.name!r}: the simulation stopped at t = {sol.t[-1]:.6g} s: {sol.message}")
    y = sol.y.T  # (m, 2 * size)
    m = times.size
    q, qd = y[:, :y.shape[1] // 2].reshape((m,) + shape), y[:, y.shape[1] // 2:].reshape((m,) + shape)
    tau = np.stack([np.array(drive(times[k], q[k], qd[k]), dtype=float) for k in range(m)])
    qdd = forward_dynamics(robot, q, qd, tau, gravity=gravity, friction=friction)
    return Simulation(readonly(times), readonly(q), readonly(qd), readonly(qdd), readonly(tau), int(sol.nfev))
