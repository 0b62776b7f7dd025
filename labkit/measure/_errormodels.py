"""Error models of a calibration's confidence intervals (:func:`labkit.measure.calibrate`).

The readings of one pose are rarely independent: the joints stopped a little off
in their deadband or had not quite settled, the ruler was laid once for three
readings, so every reading of that pose is off the same way, and the stated
uncertainty (a camera's, a ruler's resolution) says nothing of that shared error.
Two models turn the residuals of a least-squares fit into a covariance of the
fitted parameters:

``"per_pose"``
    the poses are clusters: the cluster-robust (sandwich) covariance with the CR2
    small-sample correction (Bell and McCaffrey 2002), Student t with poses -
    parameters degrees of freedom; any error shared within a pose, any
    misweighting between poses;
``"independent"``
    every measured component independent with one variance (``s^2 (J^T J)^-1``),
    measured components - parameters degrees of freedom.

With weights from stated uncertainties, :func:`_shared_variance` estimates the
variance a pose's readings share (Paule-Mandel), added to every stated variance
before the final fit.
"""

from __future__ import annotations

import numpy as np

__all__ = ["ERROR_MODELS"]

#: how the scatter of the residuals gives the parameters' intervals (see :func:`calibrate`)
ERROR_MODELS = ("per_pose", "independent")


def _covariance(J, r, poses, errors):
    """Covariance of the fitted parameters, shape (p, p), and the degrees of freedom of their t intervals.

    Parameters
    ----------
    J : ndarray, shape (m, p)
        Jacobian of the weighted residuals at the solution.
    r : ndarray, shape (m,)
        Weighted residuals at the solution.
    poses : ndarray, shape (m,)
        The pose of each residual.
    errors : {"per_pose", "independent"}

    Returns
    -------
    cov : ndarray, shape (p, p)
    dof : int

    Notes
    -----
    ``"per_pose"``: the cluster-robust (sandwich) covariance with the poses as clusters,
    ``B M B`` with ``B = (J^T J)^-1`` and ``M = sum_g J_g^T A_g r_g r_g^T A_g J_g``,
    ``A_g = (I - J_g B J_g^T)^-1/2`` (the CR2 small-sample correction of Bell and
    McCaffrey), and ``G - p`` degrees of freedom for ``G`` poses: the readings of one
    pose may share any error (a joint that stopped short in its deadband or had not
    settled, a misplaced ruler) and the stated uncertainties need not be the whole
    error; what counts is how the poses scatter. ``"independent"``: every measured
    component independent with one variance, ``s^2 B``, ``m - p`` degrees of freedom.
    """
    m, p = J.shape
    bread = np.linalg.inv(J.T @ J)
    if errors == "independent":
        return (r @ r / (m - p)) * bread, m - p
    meat = np.zeros((p, p))
    labels = np.unique(poses)
    for g in labels:
        idx = poses == g
        Jg = J[idx]
        w, V = np.linalg.eigh(np.eye(len(Jg)) - Jg @ bread @ Jg.T)
        rg = V @ ((V.T @ r[idx]) / np.sqrt(np.clip(w, 1e-9, None)))
        u = Jg.T @ rg
        meat += np.outer(u, u)
    return bread @ meat @ bread, len(labels) - p


def _shared_variance(residuals, sigma, dof):
    """The variance ``tau^2 >= 0`` with ``sum r^2 / (sigma^2 + tau^2) = dof`` (Paule-Mandel) [m^2]."""
    from scipy.optimize import brentq

    r2, s2 = residuals ** 2, sigma ** 2

    def excess(tau2):
        return float(np.sum(r2 / (s2 + tau2))) - dof

    if excess(0.0) <= 0:
        return 0.0
    return brentq(excess, 0.0, float(np.sum(r2)) / dof, xtol=1e-18, rtol=1e-8)
