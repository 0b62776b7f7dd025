"""The damped least-squares step of the LM loop, written once against a small linear algebra (private).

:func:`step` is the formula; :data:`MATRICES` evaluates it on numpy's batched
matrices (:class:`labkit.kinematics.ik._lm.Batch`: LU solves of the normal
equations for a batch at once), :class:`Lists` on nested lists of floats or
of traced symbols (:class:`labkit.kinematics.ik._lm.Floats` compiles one
target's step into straight-line code: a Cholesky solve of the 6 x 6 normal
equations there costs less than one LAPACK call's overhead).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np


def step(la, J, e, lam):
    """Damped least-squares step: ``(J^T J + lam I)^-1 J^T e``, or ``J^T (J J^T + lam I)^-1 e`` when ``J`` is wide.

    Written once, against a small linear algebra ``la``: :data:`MATRICES`
    (numpy, a batch) or :class:`Lists` (nested lists, one target; traced
    with the clip into straight-line code by
    :class:`~labkit.kinematics.ik._lm.Floats`).

    Parameters
    ----------
    la : MATRICES or Lists
        How matrices are multiplied, damped and solved.
    J : matrix, shape (..., m, n)
        Task rows of the Jacobian.
    e : vector, shape (..., m)
        Task error [m, rad].
    lam : ndarray, shape (...), or float
        Damping.

    Returns
    -------
    vector, shape (..., n)
        Joint step [rad, m].
    """
    Jt = la.transpose(J)
    if la.wide(J):
        return la.times(Jt, la.solve(la.damped(la.times(J, Jt), lam), e))
    return la.solve(la.damped(la.times(Jt, J), lam), la.times(Jt, e))


def _times(A, B):
    """``A @ B`` of batched matrices, ``B`` a matrix (..., k, l) or a vector (..., k)."""
    return A @ B if B.ndim == A.ndim else (A @ B[..., None])[..., 0]


def _damped(A, lam):
    """``A + lam I`` of batched square matrices (``lam`` (...,))."""
    return A + np.asarray(lam)[..., None, None] * np.eye(A.shape[-1])


def _solve(A, b):
    """``A^-1 b`` of batched matrices and vectors (LU: ``numpy.linalg.solve``)."""
    return np.linalg.solve(A, b[..., None])[..., 0]


#: :func:`step`'s linear algebra on numpy arrays: matrices (..., k, l), vectors (..., k)
MATRICES = SimpleNamespace(transpose=lambda A: A.swapaxes(-1, -2), wide=lambda J: J.shape[-2] < J.shape[-1],
                           times=_times, damped=_damped, solve=_solve)


class Lists:
    """:func:`step`'s linear algebra on nested lists: a matrix is a list of rows, a vector a list.

    The entries are floats, or symbols of :data:`~labkit.kinematics.ik._trace.TRACE`
    (so :class:`~labkit.kinematics.ik._lm.Floats` compiles a target's whole
    step into straight-line code);
    ``xp`` gives the square root. The solve is a Cholesky factorisation: the
    damped normal matrix is symmetric positive definite, and only its lower
    triangle is read (what nothing reads, compiled code does not compute). It
    raises ``ValueError`` or ``ZeroDivisionError`` where rounding left the
    matrix not positive definite (the caller then solves it with
    :data:`MATRICES`).

    Parameters
    ----------
    xp : namespace
        :data:`~labkit.kinematics.ik._xp.FLOATS` or :data:`~labkit.kinematics.ik._trace.TRACE`.
    """

    def __init__(self, xp):
        self.xp = xp

    @staticmethod
    def transpose(A):
        """``A^T``.

        Parameters
        ----------
        A : list of list, shape (k, l)

        Returns
        -------
        list of list, shape (l, k)
        """
        return [list(col) for col in zip(*A)]

    @staticmethod
    def wide(J):
        """Whether ``J`` has fewer rows than columns.

        Parameters
        ----------
        J : list of list, shape (m, n)

        Returns
        -------
        bool
        """
        return len(J) < len(J[0])

    @staticmethod
    def times(A, B):
        """``A B``.

        Parameters
        ----------
        A : list of list, shape (k, l)
        B : list of list, shape (l, p), or list, shape (l,)
            A matrix or a vector.

        Returns
        -------
        list of list, shape (k, p), or list, shape (k,)
        """
        vector = not isinstance(B[0], list)
        cols = [B] if vector else Lists.transpose(B)
        out = []
        for row in A:
            sums = []
            for col in cols:
                s = row[0] * col[0]
                for a, b in zip(row[1:], col[1:]):
                    s = s + a * b
                sums.append(s)
            out.append(sums[0] if vector else sums)
        return out

    @staticmethod
    def damped(A, lam):
        """``A + lam I``.

        Parameters
        ----------
        A : list of list, shape (k, k)
        lam : float or symbol
            Damping.

        Returns
        -------
        list of list, shape (k, k)
        """
        return [[a + lam if i == j else a for j, a in enumerate(row)] for i, row in enumerate(A)]

    def solve(self, A, b):
        """``A^-1 b`` for a symmetric positive definite ``A``, by Cholesky (``A = L L^T``; lower triangle read).

        Parameters
        ----------
        A : list of list, shape (k, k)
        b : list, shape (k,)

        Returns
        -------
        list, shape (k,)

        Raises
        ------
        ValueError, ZeroDivisionError
            ``A`` is not positive definite (a pivot <= 0; on floats).
        """
        k = len(b)
        L = [[None] * k for _ in range(k)]
        for i in range(k):
            for j in range(i + 1):
                s = A[i][j]
                for p in range(j):
                    s = s - L[i][p] * L[j][p]
                L[i][j] = self.xp.sqrt(s) if i == j else s / L[j][j]
        y = []
        for i in range(k):  # L y = b
            s = b[i]
            for p in range(i):
                s = s - L[i][p] * y[p]
            y.append(s / L[i][i])
        x = [None] * k
        for i in reversed(range(k)):  # L^T x = y
            s = y[i]
            for p in range(i + 1, k):
                s = s - L[p][i] * x[p]
            x[i] = s / L[i][i]
        return x
