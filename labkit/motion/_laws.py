"""Time-law constructors: cubic, quintic, linear and LSPB moves, minimum durations, time grids."""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import BPoly, CubicHermiteSpline, PPoly

from labkit.exceptions import ShapeError, TrajectoryError
from labkit.validation import as_batch, as_number
from labkit.motion._timelaw import LawName, TimeLaw, _ALIASES, _POINT_LAWS

__all__ = ["cubic_law", "quintic_law", "lspb_law", "linear_law", "make_law", "minimum_duration", "time_grid"]



# -- constructors ---------------------------------------------------------------

#: durations a time law accepts [s]: below 1 ns or above ~30 years the float arithmetic of the laws breaks down
_MIN_DURATION, _MAX_DURATION = 1e-9, 1e9
#: most samples a time grid makes (10^7 samples of 8 bytes: 80 MB per array)
_MAX_SAMPLES = 10_000_000


def _number(value, name, unit="s", error=TrajectoryError):
    """``value`` as a finite float, else ``error`` saying what was expected and what came."""
    return as_number(value, name, unit=unit, error=error)


def _check_duration(duration, t0):
    try:
        d = math.nan if isinstance(duration, (bool, np.bool_)) else float(duration)
    except (TypeError, ValueError):
        d = math.nan
    if not _MIN_DURATION <= d <= _MAX_DURATION:
        raise TrajectoryError(f"expected a positive finite duration [s] within {_MIN_DURATION:g}..{_MAX_DURATION:g} s, "
                              f"got {duration!r}")
    duration = d
    _number(t0, "the start time t0")
    return duration


def _values(*arrays, names):
    """Broadcast boundary values to one shape, checking finiteness."""
    out = []
    for a, name in zip(arrays, names):
        out.append(as_batch(a, (), name))
    try:
        return np.broadcast_arrays(*out)
    except ValueError:
        shapes = ", ".join(f"{n} {np.shape(a)}" for a, n in zip(out, names))
        raise ShapeError(f"expected boundary values of one shape, got {shapes}") from None


def _bounds(value, name, shape):
    """A speed or acceleration bound broadcast to ``shape``: positive numbers, never NaN.

    ``None`` means unbounded (``inf`` inside; a per-coordinate ``inf``, as a
    robot without a limit on one joint gives, is unbounded too)."""
    if value is None:
        return np.full(shape, math.inf)
    try:
        arr = np.broadcast_to(as_batch(value, (), name, finite=False), shape)
    except (ShapeError, ValueError):
        raise TrajectoryError(f"expected {name} as positive numbers (None: unbounded) of shape {shape}, "
                              f"got {value!r}") from None
    if np.any(np.isnan(arr)) or np.any(arr <= 0):
        raise TrajectoryError(f"expected positive {name} (None: unbounded), got {value!r}")
    return arr


def cubic_law(q0, qf, duration, *, v0=0.0, vf=0.0, t0=0.0):
    """Cubic polynomial between two values with given boundary velocities.

    ``u(t) = a0 + a1 t + a2 t^2 + a3 t^3`` (``t`` from ``t0``) with
    ``u(0) = q0, u(T) = qf, u'(0) = v0, u'(T) = vf``; rest to rest by default,
    where ``a0 = q0, a1 = 0, a2 = 3 (qf - q0) / T^2, a3 = -2 (qf - q0) / T^3``.

    Parameters
    ----------
    q0, qf : array_like, shape (...)
        Start and end values [rad, m, or any unit].
    duration : float
        ``T`` [s].
    v0, vf : array_like, shape (...)
        Boundary velocities [units/s].
    t0 : float
        Start time [s].

    Returns
    -------
    TimeLaw

    Examples
    --------
    >>> law = cubic_law([0.0, 0.0, 1.57], [-0.8, 0.8, 0.8], 5.0)  # seed 003, task 2
    >>> law.coefficients[0, 2]  # a2 per joint
    array([-0.096 ,  0.096 , -0.0924])
    """
    T = _check_duration(duration, t0)
    q0, qf, v0, vf = _values(q0, qf, v0, vf, names=("q0", "qf", "v0", "vf"))
    spl = CubicHermiteSpline([t0, t0 + T], np.stack([q0, qf]), np.stack([v0, vf]), axis=0)
    return TimeLaw(PPoly(spl.c, spl.x), LawName.CUBIC)


def quintic_law(q0, qf, duration, *, v0=0.0, vf=0.0, a0=0.0, af=0.0, t0=0.0):
    """Quintic polynomial with boundary positions, velocities and accelerations.

    Parameters
    ----------
    q0, qf : array_like, shape (...)
        Start and end values.
    duration : float
        ``T`` [s].
    v0, vf, a0, af : array_like, shape (...)
        Boundary velocities [units/s] and accelerations [units/s^2].
    t0 : float
        Start time [s].

    Returns
    -------
    TimeLaw
        Degree 5, coefficients ``a0 .. a5``.

    Examples
    --------
    >>> law = quintic_law(0.0, 1.0, 1.0)
    >>> law.coefficients[0].round(6)
    array([  0.,   0.,   0.,  10., -15.,   6.])
    """
    T = _check_duration(duration, t0)
    vals = _values(q0, qf, v0, vf, a0, af, names=("q0", "qf", "v0", "vf", "a0", "af"))
    q0, qf, v0, vf, a0, af = vals
    shape = q0.shape
    flat = [v.reshape(-1) for v in vals]
    cols = []
    for j in range(flat[0].size):
        b = BPoly.from_derivatives(
            [t0, t0 + T],
            [[flat[0][j], flat[2][j], flat[4][j]], [flat[1][j], flat[3][j], flat[5][j]]],
        )
        cols.append(PPoly.from_bernstein_basis(b).c[:, 0])
    c = np.stack(cols, axis=-1).reshape((6, 1) + shape)
    return TimeLaw(PPoly(c, [t0, t0 + T]), LawName.QUINTIC)


def linear_law(q0, qf, duration, *, t0=0.0):
    """Constant-velocity move (velocity jumps at the ends; for comparison).

    Parameters
    ----------
    q0, qf : array_like, shape (...)
        Start and end values [rad, m, or any unit].
    duration : float
        ``T`` [s], positive.
    t0 : float
        Start time [s].

    Returns
    -------
    TimeLaw
        Degree 1.

    Raises
    ------
    TrajectoryError
        A non-positive or non-finite duration.
    ShapeError
        ``q0`` and ``qf`` do not broadcast, or hold non-finite values.

    Examples
    --------
    >>> float(linear_law(0.0, 2.0, 4.0).velocity(1.0))
    0.5
    """
    T = _check_duration(duration, t0)
    q0, qf = _values(q0, qf, names=("q0", "qf"))
    c = np.stack([(qf - q0) / T, q0])[:, None]
    return TimeLaw(PPoly(c, [t0, t0 + T]), LawName.LINEAR)


def _lspb_unit_blend(T, v_max, a_max, blend_time, distance):
    """Blend time of a synchronised LSPB covering ``distance`` (array) in T."""
    given = sum(x is not None for x in (v_max, a_max, blend_time))
    if given > 1:
        raise TrajectoryError("give at most one of v_max, a_max and blend_time for an LSPB law")
    D = np.abs(distance)
    Dmax = float(np.max(D)) if D.size else 0.0
    if blend_time is not None:
        tb = _number(blend_time, "blend_time")
        if not 0 < tb <= T / 2:
            raise TrajectoryError(f"expected 0 < blend_time <= T/2 = {T / 2:.6g} s, got {tb!r}")
        return tb
    if Dmax == 0.0:
        return T / 3
    if v_max is not None:
        vm = _bounds(v_max, "v_max", D.shape)
        if np.any(vm <= 0):
            raise TrajectoryError(f"expected positive v_max, got {v_max!r}")
        moving = D > 0
        sdot = float(np.min(vm[moving] / D[moving]))  # cruise rate of s in [0, 1]
        if sdot * T <= 1.0:
            need = float(np.max(D[moving] / vm[moving]))
            raise TrajectoryError(
                f"v_max too low for an LSPB move in {T:.6g} s: expected a cruise speed above "
                f"distance/T, got v_max {v_max!r}; with this v_max the minimum duration is above {need:.6g} s"
            )
        if sdot * T > 2.0:  # v_max higher than needed: triangular profile
            return T / 2
        return T - 1.0 / sdot
    if a_max is not None:
        am = _bounds(a_max, "a_max", D.shape)
        if np.any(am <= 0) or not np.all(np.isfinite(am)):
            raise TrajectoryError(f"expected a positive finite a_max (an LSPB law blends with it), got {a_max!r}")
        moving = D > 0
        sdd = float(np.min(am[moving] / D[moving]))
        disc = sdd**2 * T**2 - 4 * sdd
        if disc < 0:
            need = 2 * math.sqrt(1.0 / sdd)
            raise TrajectoryError(
                f"a_max too low for an LSPB move in {T:.6g} s: expected a_max >= {4 / T**2:.6g} x distance, "
                f"got {a_max!r} (minimum duration {need:.6g} s)"
            )
        return T / 2 - math.sqrt(disc) / (2 * sdd)
    return T / 3  # default: cruise at 1.5 x the mean speed


def lspb_law(q0, qf, duration, *, v_max=None, a_max=None, blend_time=None, t0=0.0):
    """Linear segment with parabolic blends (trapezoidal velocity), rest to rest.

    All values move in sync: ``u(t) = q0 + (qf - q0) s(t)`` with one scalar
    trapezoidal profile ``s`` from 0 to 1. Give at most one of ``v_max``,
    ``a_max`` or ``blend_time``; the default blend time is ``T / 3`` (cruise
    speed 1.5 times the mean speed).

    Parameters
    ----------
    q0, qf : array_like, shape (...)
    duration : float
        ``T`` [s].
    v_max : float or array_like, shape (...), optional
        Cruise speed bound per value [units/s]; the slowest value sets the
        profile. Must exceed ``|qf - q0| / T``.
    a_max : float or array_like, optional
        Blend acceleration [units/s^2]; must be at least ``4 |qf - q0| / T^2``.
    blend_time : float, optional
        ``t_b`` [s], ``0 < t_b <= T / 2``.
    t0 : float
        Start time [s].

    Returns
    -------
    TimeLaw
        Three segments (blend, cruise, blend) of degree 2.

    Raises
    ------
    TrajectoryError
        If the bound cannot be met in ``T``; the message gives the minimum duration.

    Examples
    --------
    >>> law = lspb_law(0.0, 1.0, 3.0)
    >>> law.breaks
    array([0., 1., 2., 3.])
    >>> float(law.velocity(1.5))
    0.5
    """
    T = _check_duration(duration, t0)
    q0, qf = _values(q0, qf, names=("q0", "qf"))
    D = qf - q0
    tb = _lspb_unit_blend(T, v_max, a_max, blend_time, D)
    V = 1.0 / (T - tb)  # cruise rate of s
    A = V / tb
    # s(t) on [0, tb], [tb, T - tb], [T - tb, T]; coefficients descending (a2, a1, a0)
    s_tb = 0.5 * A * tb**2
    sc = np.array(
        [
            [0.5 * A, 0.0, -0.5 * A],
            [0.0, V, V],
            [0.0, s_tb, 1.0 - s_tb],
        ]
    )
    x = [t0, t0 + tb, t0 + T - tb, t0 + T]
    if T - 2 * tb <= 1e-12 * T:  # triangular: drop the empty cruise segment
        sc = sc[:, [0, 2]]
        x = [t0, t0 + tb, t0 + T]
    c = sc.reshape(sc.shape + (1,) * D.ndim) * D
    c[2] += q0
    return TimeLaw(PPoly(c, x), LawName.LSPB)


def make_law(law, q0, qf, duration, **options):
    """Build a point-to-point law by name.

    Parameters
    ----------
    law : {"cubic", "quintic", "lspb", "linear"} or LawName
        ``"trapezoid"`` is accepted for ``"lspb"``.
    q0, qf, duration, **options
        As for :func:`cubic_law`, :func:`quintic_law`, :func:`lspb_law`, :func:`linear_law`.

    Returns
    -------
    TimeLaw

    Examples
    --------
    >>> make_law("quintic", 0.0, 1.0, 2.0).degree
    5
    """
    name = _law_name(law, _POINT_LAWS)
    fn = {LawName.CUBIC: cubic_law, LawName.QUINTIC: quintic_law, LawName.LSPB: lspb_law, LawName.LINEAR: linear_law}
    return fn[name](q0, qf, duration, **options)


def _law_name(law, allowed):
    """The :class:`LawName` of ``law`` (a name, an alias such as ``"trapezoid"``, or a member) among ``allowed``."""
    return LawName.parse(_ALIASES.get(law, law) if isinstance(law, str) else law, allowed)


# Peak speed and acceleration of the rest-to-rest laws per unit distance and
# unit duration: v_peak = cv D / T, a_peak = ca D / T^2.
_PEAKS = {
    LawName.CUBIC: (1.5, 6.0),
    LawName.QUINTIC: (15.0 / 8.0, 10.0 / math.sqrt(3.0)),
}


def minimum_duration(distance, *, v_max=None, a_max=None, law="cubic"):
    """Shortest rest-to-rest duration that respects speed/acceleration bounds.

    Parameters
    ----------
    distance : array_like, shape (...)
        ``|qf - q0|`` per value [units].
    v_max, a_max : float or array_like, shape (...), optional
        Bounds [units/s, units/s^2]; ``None`` (default) means unbounded.
    law : {"cubic", "quintic", "lspb"} or LawName
        The time law whose peaks are bounded.

    Returns
    -------
    float
        The smallest ``T`` [s] (0 if nothing moves or nothing is bounded).

    Examples
    --------
    >>> minimum_duration(0.1487, v_max=0.0446)  # seed 000: 1.5 D / v
    5.001121076233184
    """
    name = _law_name(law, (LawName.CUBIC, LawName.QUINTIC, LawName.LSPB))
    (D,) = _values(distance, names=["distance"])
    D = np.abs(D)
    v = _bounds(v_max, "v_max", D.shape)
    a = _bounds(a_max, "a_max", D.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        if name is LawName.LSPB:
            tri = D <= v**2 / a  # never reaches v: triangular profile
            T = np.where(tri, 2 * np.sqrt(D / a), D / v + v / a)
        else:
            cv, ca = _PEAKS[name]
            T = np.maximum(cv * D / v, np.where(np.isinf(a), 0.0, np.sqrt(ca * D / a)))
    T = np.where(D > 0, T, 0.0)
    if not np.all(np.isfinite(T)):
        raise TrajectoryError(f"expected a distance and bounds whose duration is a finite number of seconds, got "
                              f"distance {distance!r}, v_max {v_max!r}, a_max {a_max!r}")
    return float(np.max(T)) if T.size else 0.0


def time_grid(t0, tf, dt):
    """Samples ``t0, t0 + dt, ...`` up to ``tf`` (``tf`` appended if off-grid).

    Parameters
    ----------
    t0, tf : float
        Start and end [s].
    dt : float
        Step [s] (0.1 s in seed 000).

    Returns
    -------
    ndarray, shape (N,)

    Examples
    --------
    >>> time_grid(0.0, 5.0, 0.1).size  # MATLAB 0:0.1:5
    51
    """
    dt = _number(dt, "a time step dt")
    if dt <= 0:
        raise TrajectoryError(f"expected a positive time step dt [s], got {dt!r}")
    t0, tf = _number(t0, "the start time t0"), _number(tf, "the end time tf")
    span = tf - t0
    if not 0 <= span < math.inf:
        raise TrajectoryError(f"expected tf >= t0 (and tf - t0 finite), got t0 = {t0!r}, tf = {tf!r}")
    if span / dt > _MAX_SAMPLES:
        raise TrajectoryError(f"expected at most {_MAX_SAMPLES} samples, got (tf - t0) / dt = {span / dt:.3g} "
                              f"(tf - t0 = {span:g} s, dt = {dt:g} s): use a larger dt")
    k = int(math.floor(span / dt + 1e-9))
    t = float(t0) + dt * np.arange(k + 1)
    if span - k * dt > 1e-9 * max(1.0, span):
        t = np.append(t, float(tf))
    else:
        t[-1] = float(tf) if k > 0 else t[-1]
    return t
