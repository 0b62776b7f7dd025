"""The two array namespaces every closed-form family runs on (private).

A family's formulas are written once, on the components of its target (``x``,
``y``, ``z`` or the sixteen entries of a pose) with the few functions below,
read from an ``xp`` argument:

* :data:`NUMPY` - the components are ``(N,)`` arrays: a batch of targets;
* :data:`FLOATS` - the components are Python floats: one target, without
  the array bookkeeping that costs far more than the arithmetic for one
  target.

Comparisons combine with ``&`` and ``|`` in both (Python bools support them).
``per_branch(f, branches, shared)`` runs the formulas ``f`` of one branch for
every branch: one call on the branches' rows end to end with numpy (fewer,
longer calls), one call per branch on floats.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from labkit.rotations import wrap_angle

__all__ = ["NUMPY", "FLOATS"]


def _per_branch_numpy(f, branches, shared):
    """``f(*branch, *shared)`` for every branch in one call, on the branches' rows end to end."""
    k = len(branches)
    n = max(np.size(v) for v in (*branches[0], *shared))
    args = [np.concatenate([np.broadcast_to(b[i], (n,)) for b in branches]) for i in range(len(branches[0]))]
    args += [np.tile(np.broadcast_to(v, (n,)), k) for v in shared]
    out = f(*args)
    return [tuple(o[j * n:(j + 1) * n] for o in out) for j in range(k)]


def _per_branch_floats(f, branches, shared):
    """``f(*branch, *shared)`` for every branch, one call each."""
    return [f(*b, *shared) for b in branches]


def _where(cond, a, b):
    return a if cond else b


def _clip(x, lo, hi):
    return lo if x < lo else hi if x > hi else x


def _maximum(a, b):
    return a if a >= b else b


def _minimum(a, b):
    return a if a <= b else b


#: numpy ufuncs on (N,) components
NUMPY = SimpleNamespace(
    sqrt=np.sqrt, arctan2=np.arctan2, arccos=np.arccos, cos=np.cos, sin=np.sin, tan=np.tan, abs=np.abs,
    hypot=np.hypot,
    where=np.where, clip=np.clip, maximum=np.maximum, minimum=np.minimum, logical_not=np.logical_not,
    isfinite=np.isfinite, wrap=wrap_angle, per_branch=_per_branch_numpy, batch=True,
)

#: the same functions on Python floats
FLOATS = SimpleNamespace(
    sqrt=math.sqrt, arctan2=math.atan2, arccos=math.acos, cos=math.cos, sin=math.sin, tan=math.tan, abs=abs,
    hypot=math.hypot,
    where=_where, clip=_clip, maximum=_maximum, minimum=_minimum, logical_not=lambda c: not c,
    isfinite=math.isfinite, wrap=wrap_angle, per_branch=_per_branch_floats, batch=False,
)
