"""The Lagrangian derivation of a small arm's dynamics with sympy: ``M(q)``, ``C(q, qd)``, ``g(q)``.

For the 2- and 3-joint arms of a lab handout (planar 2R/3R, the seed 000 arm): the link
frames come from :func:`labkit.kinematics.symbolic.link_transforms` (the DH recursion a student
derives by hand), each link's centre of mass and inertia from the robot file (exact rationals),
the masses are symbols ``m_1 .. m_n`` and gravity a symbol ``g``. Then

* kinetic energy ``K = sum_i (m_i |v_ci|^2 + w_i . I_i w_i) / 2 = qd^T M qd / 2`` with
  ``v_ci = dc_i/dt = Jv_i qd`` and ``[w_i]x = dR_i/dt R_i^T`` (``w_i = Jw_i qd``), so
  ``M = sum_i m_i Jv_i^T Jv_i + Jw_i^T R_i I_i R_i^T Jw_i`` (plus the motors' ``G^2 Jm`` on the
  diagonal);
* potential energy ``V = sum_i m_i g (up . c_i)``;
* the Euler-Lagrange equations: ``C`` from the Christoffel symbols of ``M``, ``g = dV/dq``.

The numeric functions of :mod:`labkit.dynamics` are checked against these expressions
(``tests/dynamics/test_symbolic.py``): an independent derivation, not a second transcription.
Simplification is ``trigsimp`` entry by entry: quick for three joints, slow beyond.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from labkit.dynamics._model import STANDARD_GRAVITY
from labkit.exceptions import RobotError, ShapeError
from labkit.kinematics.symbolic import joint_symbols, latex, link_transforms

__all__ = ["SymbolicDynamics", "lagrangian_dynamics"]


def _sp():
    import sympy  # imported where used: sympy is slow to import

    return sympy


def _unskew(W):
    """``w`` of a skew-symmetric ``[w]x`` (3, 3), as a column."""
    return _sp().Matrix([W[2, 1], W[0, 2], W[1, 0]])


def _exact(x):
    """A float as an exact rational (decimal digits kept: 0.094 -> 47/500)."""
    return _sp().Rational(Fraction(repr(float(x))))


@dataclass(frozen=True)
class SymbolicDynamics:
    """``M(q) qdd + C(q, qd) qd + g(q) = tau`` of an arm, derived symbolically.

    Attributes
    ----------
    q, qd : tuple of sympy.Symbol
        Joint variables and their rates.
    M : sympy.Matrix, shape (n, n)
        Mass matrix.
    C : sympy.Matrix, shape (n, n)
        Coriolis and centripetal matrix (Christoffel symbols of ``M``).
    g : sympy.Matrix, shape (n, 1)
        Gravity torques.
    values : dict
        The robot's number for each parameter symbol's name (masses ``m_i`` [kg], ``g``
        [m/s^2], named lengths [m]).
    """

    q: tuple
    qd: tuple
    M: object
    C: object
    g: object
    values: dict

    def latex(self):
        """LaTeX of the three terms, one equation each (for a report cell).

        Returns
        -------
        str
            ``M(q) = ...``, ``C(q, \\dot q) = ...`` and ``g(q) = ...`` joined by ``\\\\``.
        """
        return " \\\\\n".join([f"M(q) = {latex(self.M)}", f"C(q, \\dot{{q}}) = {latex(self.C)}",
                               f"g(q) = {latex(self.g)}"])

    def numeric(self, term):
        """A numpy function of the state for one term, the robot's parameter values substituted.

        Parameters
        ----------
        term : {"M", "C", "g"}

        Returns
        -------
        callable
            ``f(q, qd)`` with ``q, qd`` of shape (n,) [rad, m, rad/s, m/s] returning an ndarray
            ((n, n) for ``M`` and ``C``, (n,) for ``g``).
        """
        sp = _sp()
        if term not in ("M", "C", "g"):
            from labkit.exceptions import OptionError

            raise OptionError(f"expected term one of 'M', 'C', 'g', got {term!r}")
        expr = getattr(self, term)
        state = set(self.q + self.qd)
        unknown = sorted(str(x) for x in expr.free_symbols - state if str(x) not in self.values)
        if unknown:
            raise ShapeError(f"expected a value for every parameter of {term}, got none for {', '.join(unknown)} "
                             f"(lengths='symbolic' has no numbers: pass a mapping)")
        expr = expr.subs({x: self.values[str(x)] for x in expr.free_symbols - state})
        fn = sp.lambdify(self.q + self.qd, expr, "numpy")
        n = len(self.q)

        def f(q, qd=None):
            q = np.asarray(q, dtype=float)
            qd = np.zeros(n) if qd is None else np.asarray(qd, dtype=float)
            if q.shape != (n,) or qd.shape != (n,):
                raise ShapeError(f"expected q and qd with shape ({n},), got {q.shape} and {qd.shape}")
            out = np.asarray(fn(*q, *qd), dtype=float)
            return out.reshape(n) if term == "g" else out

        return f


def lagrangian_dynamics(robot, *, q=None, lengths=None, simplify=True):
    """Derive ``M``, ``C`` and ``g`` of a small arm from its Lagrangian.

    Parameters
    ----------
    robot : Robot
        With inertial parameters on every link (``mass``, ``com``, ``inertia``).
    q : sequence of str or sympy.Symbol, optional
        Joint variable names (default ``q1 .. qn``).
    lengths : None, "symbolic" or mapping, optional
        As :func:`labkit.kinematics.symbolic.link_transforms` (e.g. ``{"L1": 0.094}``); the
        centres of mass and inertias stay exact numbers [m, kg m^2].
    simplify : bool
        ``trigsimp`` every entry.

    Returns
    -------
    SymbolicDynamics

    Raises
    ------
    RobotError
        A link without inertial parameters.

    Examples
    --------
    >>> from labkit.robot import Link, LinkInertia, Robot
    >>> rod = LinkInertia(1.0, (-0.5, 0, 0), (0, 0.0833, 0.0833, 0, 0, 0))
    >>> arm = Robot("2r", (Link(a=1.0, inertial=rod), Link(a=1.0, inertial=rod)), up=[0, 1, 0])
    >>> dyn = lagrangian_dynamics(arm)
    >>> dyn.g[1]
    g*m_2*cos(q1 + q2)/2
    """
    sp = _sp()
    missing = [i + 1 for i, lk in enumerate(robot.links) if lk.inertial is None]
    if missing:
        raise RobotError(f"robot {robot.name!r}: expected mass, com and inertia on every joint for the Lagrangian, "
                         f"got none on joint {missing[0]}", f"joint[{missing[0]}].inertial")
    n = robot.n
    qs = joint_symbols(robot, q)
    qds = tuple(sp.Symbol(f"\\dot{{{s.name}}}", real=True) for s in qs)
    masses = sp.symbols(f"m_1:{n + 1}", positive=True)
    gsym = sp.Symbol("g", positive=True)
    base = sp.Matrix(4, 4, lambda i, j: sp.nsimplify(_exact(robot.base[i, j])))
    up = sp.Matrix([_exact(v) for v in robot.up])
    T = base
    M, V = sp.zeros(n, n), 0
    for i, (A, lk) in enumerate(zip(link_transforms(robot, q=qs, lengths=lengths), robot.links)):
        T = T * A
        R, p = T[:3, :3], T[:3, 3]
        c = p + R * sp.Matrix([_exact(v) for v in lk.inertial.com])
        Jv = c.jacobian(qs)  # v_c = Jv qd
        Jw = sp.Matrix.hstack(*(_unskew(R.diff(qj) * R.T) for qj in qs))  # w = Jw qd
        I = sp.Matrix(3, 3, lambda r, s: _exact(lk.inertial.matrix[r, s]))
        M += masses[i] * Jv.T * Jv + Jw.T * (R * I * R.T) * Jw  # K = qd^T M qd / 2
        V += masses[i] * gsym * (up.T * c)[0]
    tidy = sp.trigsimp if simplify else (lambda e: e)
    M = M.applyfunc(lambda e: tidy(sp.expand(e)))
    for i, lk in enumerate(robot.links):
        if lk.motor is not None:
            M[i, i] += _exact(lk.motor.gear_ratio) ** 2 * _exact(lk.motor.inertia)
    C = sp.Matrix(n, n, lambda k, j: tidy(sum(
        (M[k, j].diff(qs[i]) + M[k, i].diff(qs[j]) - M[i, j].diff(qs[k])) * qds[i] / 2 for i in range(n))))
    g = sp.Matrix(n, 1, lambda k, _: tidy(V.diff(qs[k])))
    values = {m.name: lk.inertial.mass for m, lk in zip(masses, robot.links)}
    values[gsym.name] = STANDARD_GRAVITY
    if isinstance(lengths, Mapping):
        values.update({str(k): float(v) for k, v in lengths.items()})
    return SymbolicDynamics(qs, qds, M, C, g, values)
