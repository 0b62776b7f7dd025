"""IK targets: the task rows of each target kind, validation, batch indices and
descriptions for error messages (private; :func:`task_rows` is public from
:mod:`labkit.kinematics`).

Used by :mod:`labkit.kinematics._ik`; the plain-Python small-target paths accept
exactly what :func:`validate_targets` accepts (and hand anything else to it).
"""

from __future__ import annotations

import math

import numpy as np

from labkit.exceptions import OptionError, ShapeError
from labkit.validation import as_batch

__all__ = ["task_rows", "batch_index", "describe_target", "validate_targets"]

#: rows of the spatial velocity [vx, vy, vz, wx, wy, wz] (and of the geometric Jacobian) per target kind
_TASK_ROWS = {"position": (0, 1, 2), "planar": (0, 1, 5), "pose": (0, 1, 2, 3, 4, 5)}


def task_rows(kind):
    """Rows of the geometric Jacobian (and of a twist) that a target kind fixes.

    Numeric IK iterates on these rows and the Cartesian trajectories of
    :mod:`labkit.motion` solve their joint rates on them.

    Parameters
    ----------
    kind : {"position", "planar", "pose"}
        What a target fixes (:func:`labkit.kinematics.target_kind`): the tool
        point ``(x, y, z)``, a planar arm's ``(x, y, phi)`` or the whole pose.

    Returns
    -------
    tuple of int
        Indices into ``[vx, vy, vz, wx, wy, wz]``.

    Raises
    ------
    OptionError
        An unknown kind.

    Examples
    --------
    >>> task_rows("planar")  # x, y and the rotation rate about z
    (0, 1, 5)
    """
    try:
        return _TASK_ROWS[kind]
    except (KeyError, TypeError):
        raise OptionError(f"unknown target kind {kind!r}; expected one of "
                          f"{', '.join(map(repr, _TASK_ROWS))}") from None


def validate_targets(target, kind):
    """Validate IK targets of one kind; flatten the batch.

    Parameters
    ----------
    target : array_like, shape (..., 3) or (..., 4, 4)
        Positions or planar ``(x, y, phi)`` [m, rad], or tool poses.
    kind : {"position", "planar", "pose"}
        What the targets fix (:func:`labkit.kinematics.target_kind`).

    Returns
    -------
    flat : ndarray, shape (N, 3) or (N, 4, 4)
        The targets, one per row.
    lead : tuple of int
        The batch shape.

    Raises
    ------
    ShapeError
        Wrong shape, non-finite values, or a pose that is not a rigid transform
        (rotation columns orthonormal to 1e-6, det > 0, last row ``[0, 0, 0, 1]``
        to 1e-12).
    """
    if kind == "pose":
        T = as_batch(target, (4, 4), "target pose")
        lead = T.shape[:-2]
        T = T.reshape(-1, 4, 4)
        c0, c1, c2 = T[:, :3, 0], T[:, :3, 1], T[:, :3, 2]
        err = np.abs(np.stack([
            (c0 * c0).sum(axis=1) - 1.0, (c1 * c1).sum(axis=1) - 1.0, (c2 * c2).sum(axis=1) - 1.0,
            (c0 * c1).sum(axis=1), (c0 * c2).sum(axis=1), (c1 * c2).sum(axis=1),
        ])).max(axis=0, initial=0.0)
        det = (np.cross(c0, c1) * c2).sum(axis=1)
        bad = (err > 1e-6) | (det < 0) | (np.abs(T[:, 3] - [0, 0, 0, 1]).max(axis=1, initial=0.0) > 1e-12)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            which = "the target" if not lead else f"target {batch_index(i, lead)}"
            raise ShapeError(
                f"expected a rigid transform as target pose (orthonormal rotation, det +1, last row "
                f"[0, 0, 0, 1]); {which} is not (max |R R^T - I| = {err[i]:.2g}, det {det[i]:.3g}, "
                f"last row {T[i, 3].tolist()})"
            )
        return T, lead
    name = "target (x, y, phi)" if kind == "planar" else "target position (x, y, z)"
    p = as_batch(target, (3,), name)
    return p.reshape(-1, 3), p.shape[:-1]


def batch_index(i, lead):
    """Index of flat row ``i`` in the batch shape ``lead``.

    Parameters
    ----------
    i : int
        Row of the flattened batch.
    lead : tuple of int
        The batch shape (``()`` for one target).

    Returns
    -------
    tuple of int or None
        None for a single target.
    """
    if not lead:
        return None
    return tuple(int(k) for k in np.unravel_index(i, lead))


def describe_target(kind, t):
    """A target in words for an error message (metres and degrees).

    Parameters
    ----------
    kind : {"position", "planar", "pose"}
        What the target fixes.
    t : ndarray, shape (3,) or (4, 4)
        The target [m, rad].

    Returns
    -------
    str
    """
    if kind == "pose":
        return "pose at ({:.4g}, {:.4g}, {:.4g}) m".format(*t[:3, 3])
    if kind == "planar":
        return "(x, y, phi) = ({:.4g} m, {:.4g} m, {:.4g} deg)".format(t[0], t[1], math.degrees(t[2]))
    return "({:.4g}, {:.4g}, {:.4g}) m".format(*t)
