"""System identification: a first- or second-order model with dead time fitted to a recorded response.

The model of a joint (a hobby servo's position loop, a bus servo's, a motor) is

* order 1: ``G(s) = K exp(-T s) / (tau s + 1)``, reported as ``wn = 1 / tau``;
* order 2: ``G(s) = K wn^2 exp(-T s) / (s^2 + 2 zeta wn s + wn^2)``.

The response to the command ``u(t)`` (a unit step at ``t = 0`` when none is given) is computed on a
uniform grid finer than the samples: the continuous model is discretised exactly for a command that is
linear between grid points (:func:`scipy.signal.cont2discrete`, ``method="foh"``) and filtered
(:func:`scipy.signal.lfilter`); the dead time shifts it (linear interpolation). The system is taken at
rest at the first sample: ``y(t) = y0 + K [x(t - T)]`` with ``x`` the response to ``u - u[0]``.
:func:`scipy.optimize.least_squares` fits ``K, wn, zeta, T, y0``; the standard errors come from its
Jacobian at the solution, ``sqrt(diag((J^T J)^-1) s^2)`` with ``s^2`` the residual variance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labkit.exceptions import MeasurementError, OptionError, ShapeError
from labkit.validation import as_batch, as_number

__all__ = ["StepFit", "fit_step_response", "model_response"]

#: grid points per sample interval of the simulated response (the dead time resolves to a fraction of it)
_REFINE = 4


@dataclass(frozen=True)
class StepFit:
    """A fitted first- or second-order model with dead time (:func:`fit_step_response`).

    Attributes
    ----------
    order : int
        1 or 2.
    gain : float
        Static gain ``K`` [units of y per unit of u].
    wn : float
        Natural frequency [rad/s] (order 1: ``1 / tau``, the corner frequency).
    zeta : float or None
        Damping ratio [1] (``None`` for order 1).
    delay : float
        Dead time ``T`` [s].
    offset : float
        Output at rest before the command changes, ``y0`` [units of y].
    residual : float
        Root mean square of the fit's residuals [units of y].
    uncertainty : dict
        One standard error per fitted parameter (``gain``, ``wn``, ``zeta``, ``delay``, ``offset``),
        from the Jacobian at the solution (same units as the parameter).
    samples : int
        Number of samples fitted.

    Examples
    --------
    >>> fit = StepFit(2, 1.0, 25.0, 0.8, 0.0, 0.0, 0.0, {}, 10)
    >>> round(fit.time_constant, 3)
    0.04
    """

    order: int
    gain: float
    wn: float
    zeta: float | None
    delay: float
    offset: float
    residual: float
    uncertainty: dict
    samples: int

    @property
    def time_constant(self):
        """``1 / wn`` [s] (order 1: the time constant ``tau``)."""
        return 1.0 / self.wn

    def transfer_function(self, *, delay_order=3):
        """The model as a python-control ``TransferFunction`` (continuous time).

        Parameters
        ----------
        delay_order : int
            Order of the Padé approximation of the dead time (:func:`control.pade`); 0 leaves the dead
            time out (the transfer function is then the delay-free part, to be shifted by :attr:`delay`).

        Returns
        -------
        control.TransferFunction
            ``y / u`` of the fitted model.

        Raises
        ------
        OptionError
            ``delay_order`` not a whole number 0..10.

        Examples
        --------
        >>> fit = StepFit(2, 2.0, 10.0, 0.5, 0.0, 0.0, 0.0, {}, 10)
        >>> G = fit.transfer_function()
        >>> round(float(G.dcgain()), 6)
        2.0
        """
        import control

        if isinstance(delay_order, bool) or not isinstance(delay_order, (int, np.integer)) \
                or not 0 <= delay_order <= 10:
            raise OptionError(f"expected delay_order a whole number 0..10, got {delay_order!r}")
        num, den = _num_den(self.order, self.gain, self.wn, self.zeta)
        G = control.tf(num, den)
        if self.delay > 0 and delay_order > 0:
            G = G * control.tf(*control.pade(self.delay, int(delay_order)))
        return G

    def predict(self, t, u=None):
        """The model's output at times ``t`` (for the command ``u``, a unit step at 0 by default).

        Parameters
        ----------
        t : array_like, shape (N,)
            Sample times [s], increasing.
        u : array_like, shape (N,), optional
            Command at those times [units of u].

        Returns
        -------
        y : ndarray, shape (N,)
            Model output [units of y], dead time exact (not a Padé approximation).
        """
        t, _, u = _signals(t, np.zeros(np.shape(t)), u)
        return model_response(t, u, self.order, self.gain, self.wn, self.zeta, self.delay, self.offset)

    def to_dataframe(self):
        """The fitted parameters with their standard errors, one row each.

        Returns
        -------
        pandas.DataFrame
            Columns ``parameter``, ``value``, ``standard error``, ``unit``.
        """
        import pandas as pd

        units = {"gain": "1", "wn": "rad/s", "zeta": "1", "delay": "s", "offset": "y"}
        rows = [(k, getattr(self, k), self.uncertainty.get(k), units[k]) for k in units
                if getattr(self, k) is not None]
        return pd.DataFrame(rows, columns=["parameter", "value", "standard error", "unit"])


def _num_den(order, gain, wn, zeta):
    if order == 1:
        return [gain * wn], [1.0, wn]
    return [gain * wn * wn], [1.0, 2.0 * zeta * wn, wn * wn]


def _signals(t, y, u):
    """Validated ``t, y, u`` (u: a unit step at t = 0 when None) as float arrays."""
    t = as_batch(t, (), "t", finite=False)
    y = as_batch(y, (), "y", finite=False)
    if t.ndim != 1 or y.shape != t.shape:
        raise MeasurementError(f"expected t and y with the same shape (N,), got {t.shape} and {y.shape}")
    if len(t) < 8:
        raise MeasurementError(f"expected at least 8 samples to fit a response, got {len(t)}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(y))):
        raise MeasurementError("expected finite t and y (a NaN or infinity was found)")
    if np.any(np.diff(t) <= 0):
        raise MeasurementError("expected strictly increasing sample times t")
    if u is None:
        if t[0] > 0:
            raise MeasurementError(f"expected the step at t = 0 within the record (t[0] <= 0), got t[0] = {t[0]:g} s")
    else:
        u = as_batch(u, (), "u", finite=False)
        if u.shape != t.shape or not np.all(np.isfinite(u)):
            raise MeasurementError(f"expected a finite command u with shape {t.shape}, got shape {u.shape}")
    return t, y, u


def model_response(t, u, order, gain, wn, zeta, delay, offset):
    """Output of the first- or second-order model with dead time, at rest at ``t[0]``.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Sample times [s], increasing.
    u : ndarray, shape (N,) or None
        Command at those times (linear in between) [units of u]; ``None``: a unit step at ``t = 0``
        (``t[0] <= 0``), exact.
    order : {1, 2}
    gain, wn, zeta, delay, offset : float
        ``K`` [y/u], natural frequency [rad/s], damping ratio [1] (ignored for order 1), dead time [s]
        and the output at rest ``y0`` [units of y].

    Returns
    -------
    y : ndarray, shape (N,)

    Examples
    --------
    >>> t = np.linspace(-0.1, 1.0, 111)
    >>> y = model_response(t, None, 1, 2.0, 10.0, None, 0.0, 0.0)
    >>> round(float(y[-1]), 3)
    2.0
    """
    from scipy.signal import lfilter

    t = as_batch(t, (), "t (sample times, s)")
    if t.ndim != 1 or t.size < 2 or not np.all(np.diff(t) > 0):
        raise ShapeError(f"expected t as increasing sample times of shape (N,), N >= 2, got {t!r}")
    if u is not None:
        u = as_batch(u, t.shape, "u (the command at the times t)")
        if u.shape != t.shape:
            raise ShapeError(f"expected u with shape {t.shape}, got {u.shape}")
    if isinstance(order, bool) or order not in (1, 2):
        raise OptionError(f"expected order 1 or 2, got {order!r}")
    gain, delay, offset = (as_number(v, name) for v, name in ((gain, "gain"), (delay, "delay"), (offset, "offset")))
    wn = as_number(wn, "wn", unit="rad/s", positive=True)
    if order == 2:
        zeta = as_number(zeta, "zeta")
        if zeta < 0:
            raise OptionError(f"expected a damping ratio zeta >= 0, got {zeta!r}")
    h = float(np.min(np.diff(t))) / _REFINE
    h = max(h, (t[-1] - t[0]) / 200_000)
    if u is None:  # a step at t = 0: a grid point at 0, the command held from there (exact)
        grid = np.arange(-math.ceil(-t[0] / h), math.floor(t[-1] / h) + 2) * h
        ug, hold = (grid >= 0).astype(float), "zoh"
    else:
        grid = np.arange(t[0], t[-1] + h, h)
        ug, hold = np.interp(grid, t, u) - u[0], "foh"
    b, a = _discrete(order, wn, zeta, h, hold)
    x = lfilter(b, a, ug)
    return offset + gain * np.interp(t - delay, grid, x, left=0.0)


def _discrete(order, wn, zeta, h, hold):
    """``(b, a)`` of the unit-gain model discretised exactly over steps ``h`` for a command that is
    constant (``hold="zoh"``) or linear (``hold="foh"``) over each step.

    With the state model ``xd = A x + B u``, ``y = x[0]`` (Franklin, Powell & Workman, *Digital
    Control*, 6.3): ``Phi = expm(A h)``, ``G1 = int_0^h expm(A s) B ds = A^-1 (Phi - I) B`` and
    ``G2 = (1/h) int_0^h expm(A s) (h - s) B ds = G1 - A^-1 Phi B + A^-1 G1 / h``; the zero-order hold
    is ``(Phi, G1)``, the first-order hold ``(Phi, Phi G2 + G1 - G2)`` with the output
    ``C (x - G2 u) + C G2 u``. ``expm(A h)`` of the 2x2 companion matrix is the closed form
    ``exp(mu h) (cosh(d h) I + sinh(d h) / d (A - mu I))``, ``mu = -zeta wn``,
    ``d = wn sqrt(zeta^2 - 1)`` (complex below critical damping; no BLAS call, which a loaded machine's
    threads make slow for a 2x2). The transfer function of ``(Phi, Bd, C, D)`` is
    ``(poly(Phi - Bd C) + (D - 1) poly(Phi)) / poly(Phi)``.
    """
    if order == 1:
        A, B = np.array([[-wn]]), np.array([wn])
        Phi = np.array([[math.exp(-wn * h)]])
    else:
        A, B = np.array([[0.0, 1.0], [-wn * wn, -2.0 * zeta * wn]]), np.array([0.0, wn * wn])
        mu, d = -zeta * wn, wn * np.sqrt(complex(zeta * zeta - 1.0))
        ch = np.cosh(d * h).real
        sh = (np.sinh(d * h) / d).real if abs(d * h) > 1e-9 else h
        Phi = math.exp(mu * h) * (ch * np.eye(2) + sh * (A - mu * np.eye(2)))
    A_inv = np.array([[-1.0 / wn]]) if order == 1 else np.array([[A[1, 1], -1.0], [-A[1, 0], 0.0]]) / (wn * wn)
    G1 = A_inv @ (Phi @ B - B)
    G2 = G1 - A_inv @ (Phi @ B) + A_inv @ G1 / h
    Bd, D = (G1, 0.0) if hold == "zoh" else (Phi @ G2 + G1 - G2, G2[0])
    BC = np.zeros_like(Phi)
    BC[:, 0] = Bd
    a = np.poly(Phi)
    return np.poly(Phi - BC) + (D - 1.0) * a, a


def _guess(t, y, u):
    """Starting values ``K, y0`` from the data: a straight-line fit of ``y`` against the command."""
    du = u - u[0]
    if not np.any(np.abs(du) > 0):
        raise MeasurementError("expected a command u that changes during the record (nothing to respond to)")
    A = np.column_stack([du, np.ones_like(du)])
    (gain, y0), *_ = np.linalg.lstsq(A, y, rcond=None)
    return float(gain) if gain != 0 else 1.0, float(y0)


def fit_step_response(t, y, *, u=None, order=2):
    """Fit a first- or second-order model with dead time to a recorded response.

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times [s], strictly increasing (irregular spacing and lost samples are fine).
    y : array_like, shape (N,)
        Measured output (a joint value [rad], ...), N >= 8.
    u : array_like, shape (N,), optional
        The command at those times [units of u] (a joint set-point [rad], ...), linear between samples;
        default: a unit step at ``t = 0`` (times before 0 show the rest value).
    order : {1, 2}
        Model order (see the module notes).

    Returns
    -------
    StepFit
        Gain, ``wn``, ``zeta``, dead time, rest value, RMS residual and standard errors.

    Raises
    ------
    MeasurementError
        ``t``, ``y`` or ``u`` of the wrong shape, not finite, too short, ``t`` not increasing, or a
        command that never changes.
    OptionError
        ``order`` not 1 or 2.

    Examples
    --------
    >>> t = np.linspace(-0.1, 1.0, 221)
    >>> y = StepFit(2, 0.5, 25.0, 0.6, 0.02, 0.1, 0.0, {}, 0).predict(t)
    >>> fit = fit_step_response(t, y)
    >>> round(fit.wn, 3), round(fit.zeta, 3), round(fit.delay, 3), round(fit.gain, 3)
    (25.0, 0.6, 0.02, 0.5)
    """
    from scipy.optimize import least_squares

    if isinstance(order, bool) or order not in (1, 2):
        raise OptionError(f"expected order 1 or 2, got {order!r}")
    t, y, u = _signals(t, y, u)
    gain0, y00 = _guess(t, y, (t >= 0).astype(float) if u is None else u)
    span, dt_min = float(t[-1] - t[0]), float(np.min(np.diff(t)))
    names = ["gain", "wn", "zeta", "delay", "offset"] if order == 2 else ["gain", "wn", "delay", "offset"]
    wn_lo, wn_hi = 0.1 / span, 20.0 * math.pi / dt_min
    scale_y = max(float(np.ptp(y)), 1e-12)

    def unpack(p):
        if order == 2:
            return p[0], p[1], p[2], p[3], p[4]
        return p[0], p[1], None, p[2], p[3]

    def residuals(p):
        return (model_response(t, u, order, *unpack(p)) - y) / scale_y

    lo = np.array([-np.inf, wn_lo, 0.02, 0.0, -np.inf] if order == 2 else [-np.inf, wn_lo, 0.0, -np.inf])
    hi = np.array([np.inf, wn_hi, 20.0, 0.5 * span, np.inf] if order == 2 else [np.inf, wn_hi, 0.5 * span, np.inf])
    # starting points: a log grid of wn (and two damping ratios), the two best refined by least squares
    starts = [[gain0, w, z, 0.0, y00] if order == 2 else [gain0, w, 0.0, y00]
              for w in np.geomspace(wn_lo * 10, wn_hi / 10, 12) for z in ((0.5, 1.2) if order == 2 else (None,))]
    starts.sort(key=lambda p: float(np.sum(residuals(p) ** 2)))
    best = None
    for p0 in starts[:2]:
        sol = least_squares(residuals, np.clip(p0, lo + 1e-12, hi - 1e-12), bounds=(lo, hi), x_scale="jac")
        if best is None or sol.cost < best.cost:
            best = sol
    res = best.fun * scale_y
    dof = max(len(t) - len(names), 1)
    s2 = float(res @ res) / dof
    J = best.jac * scale_y
    try:
        cov = np.linalg.pinv(J.T @ J) * s2
        se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    except np.linalg.LinAlgError:  # pragma: no cover - pinv converges for finite J
        se = np.full(len(names), np.inf)
    gain, wn, zeta, delay, offset = unpack(best.x)
    return StepFit(order=order, gain=float(gain), wn=float(wn), zeta=None if zeta is None else float(zeta),
                   delay=float(delay), offset=float(offset), residual=float(np.sqrt(np.mean(res * res))),
                   uncertainty={k: float(v) for k, v in zip(names, se)}, samples=len(t))
