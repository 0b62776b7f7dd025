"""Time laws: cubic, quintic, LSPB (trapezoidal velocity) and linear profiles.

A time law maps time ``t`` [s] to a value ``u(t)`` (a joint angle, a
Cartesian coordinate, or a path parameter ``s`` in [0, 1]) as a piecewise
polynomial. Every law is a :class:`TimeLaw` that wraps a
:class:`scipy.interpolate.PPoly` (built with ``CubicHermiteSpline``,
``BPoly.from_derivatives`` or ``CubicSpline``), exposes the polynomial
coefficients in the form the lab reports tabulate them,
``u(t) = a0 + a1 (t - t_i) + a2 (t - t_i)^2 + a3 (t - t_i)^3 [+ a4 ... + a5 ...]``
with ``t_i`` the start of the segment, and evaluates position, velocity,
acceleration and jerk at any times.

Values may be scalars or arrays of any shape (``q0`` of shape ``(n,)`` for
``n`` joints, ``(3,)`` for x, y, z): the law is batched over those dimensions.
Before its start and after its end a law holds its end values with zero
derivatives (seed 000: ``u(t) = u_f for t >= t_f``).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np
from scipy.interpolate import PPoly

from labkit.exceptions import OptionError, ShapeError
from labkit.validation import as_batch, as_count

__all__ = ["LawName", "TimeLaw"]


class LawName(str, Enum):
    """Names of time laws (``"cubic"``, ``"quintic"``, ``"lspb"``, ``"linear"``,
    and the via-point laws built in :mod:`labkit.motion`): what ``law=``
    takes as a string."""

    CUBIC = "cubic"
    QUINTIC = "quintic"
    LSPB = "lspb"
    LINEAR = "linear"
    VIA_CUBIC = "via_cubic"
    SPLINE = "spline"
    BLENDED = "blended"

    @classmethod
    def parse(cls, value, allowed=None):
        """Return the member for ``value``; the error lists the valid names.

        Parameters
        ----------
        value : str or LawName
            Law name (e.g. ``"quintic"``) or member.
        allowed : iterable of LawName, optional
            The members accepted here; default all.

        Returns
        -------
        LawName

        Raises
        ------
        ValueError
            ``value`` names no member, or one not in ``allowed``.
        """
        allowed = tuple(allowed or cls)
        try:
            name = cls(value)
        except ValueError:
            name = None
        if name is None or name not in allowed:
            names = ", ".join(repr(k.value) for k in allowed)
            raise OptionError(f"expected a time law in {{{names}}}, got {value!r}") from None
        return name


# "trapezoid" is the name many courses use for LSPB
_ALIASES = {"trapezoid": "lspb", "trapezoidal": "lspb"}

_POINT_LAWS = (LawName.CUBIC, LawName.QUINTIC, LawName.LSPB, LawName.LINEAR)


@dataclass(frozen=True, eq=False)
class TimeLaw:
    """A piecewise-polynomial time law ``u(t)``.

    Attributes
    ----------
    ppoly : scipy.interpolate.PPoly
        The engine; ``ppoly.c`` has shape ``(k + 1, m, *shape)`` (descending
        powers, local variable ``t - t_i``).
    name : LawName
        Which law this is (how it was built).

    Examples
    --------
    >>> from labkit.motion import cubic_law
    >>> law = cubic_law(0.0, 1.0, 2.0)
    >>> law.coefficients[0]  # a0, a1, a2, a3 of the only segment
    array([ 0.  ,  0.  ,  0.75, -0.25])
    >>> float(law.velocity(1.0))
    0.75
    """

    ppoly: PPoly
    name: LawName

    # -- description ---------------------------------------------------------
    @property
    def breaks(self):
        """Segment boundaries, shape (m + 1,) [s]."""
        return np.asarray(self.ppoly.x)

    @property
    def t0(self):
        """Start time [s]."""
        return float(self.ppoly.x[0])

    @property
    def tf(self):
        """End time [s]."""
        return float(self.ppoly.x[-1])

    @property
    def duration(self):
        """``tf - t0`` [s]."""
        return self.tf - self.t0

    @property
    def n_segments(self):
        """Number of polynomial segments ``m``."""
        return self.ppoly.c.shape[1]

    @property
    def degree(self):
        """Polynomial degree ``k`` (3 for cubic, 5 for quintic, 2 for LSPB)."""
        return self.ppoly.c.shape[0] - 1

    @property
    def shape(self):
        """Shape of one value ``u(t)`` (``()`` for a scalar law)."""
        return self.ppoly.c.shape[2:]

    @property
    def coefficients(self):
        """Coefficients ``a0 .. ak`` per segment, shape (m, k + 1, *shape).

        ``u(t) = sum_j a_j (t - t_i)^j`` on segment ``i`` (``t_i =
        breaks[i]``), the form of the seeds' tables.
        """
        return np.moveaxis(self.ppoly.c[::-1], 0, 1).copy()

    def coefficient_table(self, names=None):
        """The coefficients as a pandas DataFrame (one row per segment and value).

        Parameters
        ----------
        names : sequence of str, optional
            Names of the flattened values (default ``u``, or ``u1, u2 ...``).

        Returns
        -------
        pandas.DataFrame
            Index (segment, name); columns ``t_start``, ``t_end`` [s] and
            ``a0 .. ak`` (SI units of the value per s^j).
        """
        import pandas as pd

        coef = self.coefficients.reshape(self.n_segments, self.degree + 1, -1)
        nvals = coef.shape[2]
        if names is None:
            names = ["u"] if self.shape == () else [f"u{i + 1}" for i in range(nvals)]
        names = list(names)
        if len(names) != nvals:
            raise ShapeError(f"expected {nvals} names, got {len(names)}")
        rows, index = [], []
        x = self.breaks
        for i in range(self.n_segments):
            for j, name in enumerate(names):
                row = {"t_start": x[i], "t_end": x[i + 1]}
                row.update({f"a{p}": coef[i, p, j] for p in range(self.degree + 1)})
                rows.append(row)
                index.append((i + 1, name))
        return pd.DataFrame(rows, index=pd.MultiIndex.from_tuples(index, names=["segment", "value"]))

    # -- evaluation ----------------------------------------------------------
    def evaluate(self, t, derivative=0):
        """Value or derivative of the law at times ``t``.

        Parameters
        ----------
        t : array_like, shape (...)
            Times [s]; outside ``[t0, tf]`` the end values are held.
        derivative : int
            0 position, 1 velocity, 2 acceleration, 3 jerk.

        Returns
        -------
        ndarray, shape (..., *shape)
        """
        t = as_batch(t, (), "times t")
        derivative = as_count(derivative, "derivative")
        tc = np.clip(t, self.t0, self.tf)
        out = self.ppoly(tc, nu=derivative) if derivative else self.ppoly(tc)
        if derivative:
            outside = (t < self.t0) | (t > self.tf)
            if np.any(outside):
                out = np.array(out, copy=True)
                out[outside] = 0.0
        return out

    def position(self, t):
        """``u(t)`` [value units]; see :meth:`evaluate`.

        Parameters
        ----------
        t : array_like, shape (...)
            Times [s]; outside ``[t0, tf]`` the law holds its end values.

        Returns
        -------
        ndarray, shape (..., *shape)
            Values [value units].
        """
        return self.evaluate(t, 0)

    __call__ = position

    def velocity(self, t):
        """``du/dt`` [units/s].

        Parameters
        ----------
        t : array_like, shape (...)
            Times [s]; outside ``[t0, tf]`` the law holds its end values.

        Returns
        -------
        ndarray, shape (..., *shape)
            Velocities [units/s].
        """
        return self.evaluate(t, 1)

    def acceleration(self, t):
        """``d2u/dt2`` [units/s^2].

        Parameters
        ----------
        t : array_like, shape (...)
            Times [s]; outside ``[t0, tf]`` the law holds its end values.

        Returns
        -------
        ndarray, shape (..., *shape)
            Accelerations [units/s^2].
        """
        return self.evaluate(t, 2)

    def jerk(self, t):
        """``d3u/dt3`` [units/s^3].

        Parameters
        ----------
        t : array_like, shape (...)
            Times [s]; outside ``[t0, tf]`` the law holds its end values.

        Returns
        -------
        ndarray, shape (..., *shape)
            Jerks [units/s^3].
        """
        return self.evaluate(t, 3)

    def peak(self, derivative=1, samples=2001):
        """Largest ``|d^k u / dt^k|`` over the law (per value), dense sampling.

        Parameters
        ----------
        derivative : int
            ``k``: 0 position, 1 velocity, 2 acceleration, 3 jerk.
        samples : int
            Evenly spaced sample times over ``[t0, tf]`` (the breakpoints are
            added).

        Returns
        -------
        ndarray, shape (*shape)
            Peak magnitude per value [units/s^k].
        """
        t = np.linspace(self.t0, self.tf, as_count(samples, "samples", minimum=2))
        t = np.union1d(t, self.breaks)
        return np.max(np.abs(self.evaluate(t, derivative)), axis=0)

    def __repr__(self):
        return (
            f"TimeLaw(name={self.name.value!r}, t=[{self.t0:g}, {self.tf:g}] s, "
            f"segments={self.n_segments}, degree={self.degree}, shape={self.shape})"
        )


