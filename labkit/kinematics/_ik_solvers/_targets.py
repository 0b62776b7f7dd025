"""IK targets: the task rows of each target kind, validation (every solver's targets pass
:func:`validate_targets`), batch indices and descriptions for error messages (private;
:func:`task_rows` and :func:`target_components` are public from :mod:`labkit.kinematics`).
"""

from __future__ import annotations

import math

import numpy as np

from labkit.exceptions import OptionError, ShapeError
from labkit.kinematics._ik_solvers._elementwise import maximum
from labkit.kinematics._ik_solvers._geometry import _cross, _dot
from labkit.validation import as_batch, as_option

__all__ = ["task_rows", "target_components", "validate_targets", "COMPONENTS", "REDUCED"]

#: the components of each vector target kind, in order (a ``"pose"`` is a 4 x 4 transform)
COMPONENTS = {
    "position": ("x", "y", "z"),
    "planar": ("x", "y", "phi"),
    "position_pitch": ("x", "y", "z", "pitch"),
    "position_pitch_roll": ("x", "y", "z", "pitch", "roll"),
    "position_yaw": ("x", "y", "z", "yaw"),
}
#: target kinds of arms with fewer than 6 joints that fix an orientation too (4-DOF pitch, 5-DOF pitch and
#: roll, see :mod:`labkit.kinematics._ik_solvers._yaw_pitch_pitch_pitch`; a SCARA's yaw,
#: :mod:`labkit.kinematics._ik_solvers._scara`); they also take poses (checked by FK)
REDUCED = ("position_pitch", "position_pitch_roll", "position_yaw")

#: largest magnitude of a target's coordinates [m] and angles [rad]: a robot's workspace is metres across, and
#: beyond this the solvers' squares and steps would overflow
FARTHEST = 1e9

#: rows of the spatial velocity [vx, vy, vz, wx, wy, wz] (and of the geometric Jacobian) per target kind;
#: the pitch and roll of a reduced kind are no fixed rows: its Cartesian paths are poses (all six rows)
_TASK_ROWS = {"position": (0, 1, 2), "planar": (0, 1, 5), "pose": (0, 1, 2, 3, 4, 5),
              "position_pitch": (0, 1, 2, 3, 4, 5), "position_pitch_roll": (0, 1, 2, 3, 4, 5),
              "position_yaw": (0, 1, 2, 3, 4, 5)}


def _target_words(kind):
    """What a target of ``kind`` is, in words for messages: ``"x y z pitch"``, ``"a 4 x 4 pose"`` ...

    >>> _target_words("position_pitch_roll")
    'x y z pitch roll'
    """
    if kind == "pose":
        return "a 4 x 4 pose (at the command line: x y z roll pitch yaw)"
    return " ".join(COMPONENTS[kind])


def target_components(kind):
    """The components of a target of ``kind`` in order, as the command line takes them.

    Parameters
    ----------
    kind : {"position", "planar", "position_pitch", "position_pitch_roll", "pose"}
        A target kind (:func:`labkit.kinematics.target_kind`).

    Returns
    -------
    tuple of str
        ``("x", "y", "z")`` ...; a pose as ``("x", "y", "z", "roll", "pitch", "yaw")``.

    Examples
    --------
    >>> target_components("planar")
    ('x', 'y', 'phi')
    """
    return ("x", "y", "z", "roll", "pitch", "yaw") if as_option(kind, _TASK_ROWS, "kind") == "pose" else COMPONENTS[kind]


def task_rows(kind):
    """Rows of the geometric Jacobian (and of a twist) that a target kind fixes.

    Numeric IK iterates on these rows and the Cartesian trajectories of
    :mod:`labkit.motion` solve their joint rates on them.

    Parameters
    ----------
    kind : {"position", "planar", "pose", "position_pitch", "position_pitch_roll"}
        What a target fixes (:func:`labkit.kinematics.target_kind`): the tool
        point ``(x, y, z)``, a planar arm's ``(x, y, phi)`` or the whole pose;
        a 4- or 5-DOF arm's Cartesian paths are poses (all six rows).

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
    """Validate IK targets of ``kind`` [m, rad] (poses also for the :data:`REDUCED` kinds); flatten the batch.

    Parameters
    ----------
    target : array_like, shape (..., k) or (..., 4, 4)
    kind : str

    Returns
    -------
    flat : ndarray, shape (N, k) or (N, 4, 4)
    lead : tuple of int
        The batch shape.

    Raises
    ------
    ShapeError
        Wrong shape, non-finite values or values beyond :data:`FARTHEST`, or a pose that is not a
        rigid transform (rotation columns orthonormal to 1e-6, det > 0, last row ``[0, 0, 0, 1]``
        to 1e-12).
    """
    try:
        target = np.asarray(target, dtype=float)
    except (TypeError, ValueError) as exc:  # ragged lists, strings ...
        raise ShapeError(f"expected the target as numbers ({_target_words(kind)}), got {target!r:.80} ({exc})") \
            from None
    if kind == "pose" or (kind in REDUCED and target.shape[-2:] == (4, 4)):
        T = _finite_and_near(target, (4, 4), "target pose")
        lead = T.shape[:-2]
        T = T.reshape(-1, 4, 4)
        err, det, last = _rigid_defects(T)
        bad = ((err > 1e-6) | (det < 0) | (last > 1e-12)).nonzero()[0]
        if len(bad):
            i = int(bad[0])
            err, det = err[i], det[i]
            which = "the target" if not lead else f"target {_batch_index(i, lead)}"
            raise ShapeError(
                f"expected a rigid transform as target pose (orthonormal rotation, det +1, last row "
                f"[0, 0, 0, 1]); {which} is not (max |R R^T - I| = {err:.2g}, det {det:.3g}, "
                f"last row {T[i, 3].tolist()})"
            )
        return T, lead
    return _vector_targets(target, kind)


def _vector_targets(target, kind):
    """``(..., k)`` targets of a vector kind, with a message naming the components when the size is wrong."""
    names = COMPONENTS[kind]
    name = "target position (x, y, z)" if kind == "position" else f"target ({', '.join(names)})"
    shape = np.shape(target)
    if not shape or shape[-1] != len(names):
        got = shape[-1] if shape else 1
        missing = f"; {' '.join(names[got:])} missing" if 0 < got < len(names) else ""
        also = " or a 4 x 4 pose" if kind in REDUCED else ""
        raise ShapeError(f"expected {name} with shape (..., {len(names)}){also}, got {shape}: this arm takes "
                         f"{' '.join(names)}{missing}")
    p = _finite_and_near(target, (len(names),), name)
    return p.reshape(-1, len(names)), p.shape[:-1]


def _finite_and_near(target, last, name):
    """``as_batch(target, last, name)``, also refusing entries beyond :data:`FARTHEST` (a pose: its position).

    One comparison checks both (NaN and inf fail it too); where it fails, ``as_batch`` names a
    non-finite entry, else the first target too far is named.
    """
    arr = as_batch(target, last, name, finite=False)
    if not (np.abs(arr) <= FARTHEST).all():
        as_batch(arr, last, name)  # raises for NaN / inf
        lead = arr.shape[:-len(last)]
        rows = np.abs(arr.reshape(-1, *last)[:, :3, 3] if len(last) == 2 else arr.reshape(-1, last[0]))
        far = np.flatnonzero((rows > FARTHEST).any(axis=-1))
        if len(far):  # (a pose's far rotation entry is no rigid transform: refused after this)
            which = "" if not lead else f" (target {_batch_index(int(far[0]), lead)})"
            raise ShapeError(f"expected {name} with every {'position ' * (len(last) == 2)}entry within "
                             f"+-{FARTHEST:.0e} (m, rad), got {rows[far[0]].max():.3g}{which}: a robot's "
                             f"workspace is metres across")
    return arr


def _rigid_defects(T):
    """How far poses ``T`` (N, 4, 4) are from rigid transforms: the largest deviation of the rotation columns
    from orthonormal, the determinant, and the largest deviation of the last row from ``[0, 0, 0, 1]``."""
    t = T[0].tolist() if T.shape[0] == 1 else np.moveaxis(T, 0, -1)  # one pose: floats, cheaper than rows of one
    c0, c1, c2 = ((t[0][k], t[1][k], t[2][k]) for k in range(3))
    err = abs(_dot(c0, c0) - 1.0)
    for e in (_dot(c1, c1) - 1.0, _dot(c2, c2) - 1.0, _dot(c0, c1), _dot(c0, c2), _dot(c1, c2)):
        err = maximum(err, abs(e))
    det = _dot(_cross(c0, c1), c2)
    return np.reshape(err, -1), np.reshape(det, -1), np.abs(T[:, 3] - _LAST_ROW).max(axis=1)


_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])


def _batch_index(i, lead):
    """Index of flat row ``i`` in the batch shape ``lead`` (None for one target, ``lead = ()``)."""
    if not lead:
        return None
    return tuple(int(k) for k in np.unravel_index(i, lead))


def _describe_target(kind, t):
    """A target ``t`` (k,) or (4, 4) [m, rad] in words for an error message (metres and degrees)."""
    if kind in REDUCED and np.ndim(t) == 1:
        angles = ", ".join(f"{name} = {math.degrees(v):.4g} deg" for name, v in zip(COMPONENTS[kind][3:], t[3:]))
        return "({:.4g}, {:.4g}, {:.4g}) m, ".format(*t[:3]) + angles
    if np.ndim(t) == 2:
        return "pose at ({:.4g}, {:.4g}, {:.4g}) m".format(*t[:3, 3])
    if kind == "planar":
        return "(x, y, phi) = ({:.4g} m, {:.4g} m, {:.4g} deg)".format(t[0], t[1], math.degrees(t[2]))
    return "({:.4g}, {:.4g}, {:.4g}) m".format(*t)
