"""The kinematic chain's constants and where joint values enter it (private).

:func:`chain` turns a robot's DH rows into the per-link constants the
compiled programs of :mod:`labkit.kinematics._program` are built from, cached
per robot object (:func:`_per_robot`, the keyed cache every per-robot constant
of the kinematics uses; :func:`_by_content` for what depends on the robot's
content alone). :func:`prepare` is the one place joint values enter the chain:
it validates ``q`` and returns the effective joint values, shape ``(N, n)``,
that every evaluator runs on.
"""

from __future__ import annotations

import functools
import math
import weakref
from dataclasses import dataclass, field

import numpy as np

from labkit.kinematics._program import _chain_structure
from labkit.robot.types import Convention
from labkit.validation import as_vector, check_robot


#: contents a :func:`_by_content` cache keeps
CONTENTS_KEPT = 64


def _per_robot(func):
    """``func(robot)`` cached per robot object in a weak keyed cache (``Robot`` stays plain frozen data)."""
    cache = weakref.WeakKeyDictionary()

    @functools.wraps(func)
    def cached(robot):
        try:
            return cache[robot]
        except (KeyError, TypeError):  # not cached yet, or no robot at all (a str cannot be weakly referenced)
            value = cache[robot] = func(check_robot(robot))
            return value

    return cached


def _by_content(func):
    """``func(robot)`` cached by the robot's content (links, convention, base, tool, up: a fresh load or a copy
    finds an earlier value; the last :data:`CONTENTS_KEPT` are kept), and per robot object."""
    cache = {}

    @_per_robot
    @functools.wraps(func)
    def cached(robot):
        key = (robot.convention, robot.links, robot.base.tobytes(), robot.tool.tobytes(),
               np.asarray(robot.up, dtype=float).tobytes())
        try:
            return cache[key]
        except KeyError:
            if len(cache) >= CONTENTS_KEPT:
                cache.pop(next(iter(cache)))
            value = cache[key] = func(robot)
            return value

    return cached


def _clean(v):
    """cos/sin of DH constants with exact zeros and ones (cos(pi/2) -> 0)."""
    return 0.0 if abs(v) < 1e-15 else (1.0 if abs(v - 1) < 1e-15 else (-1.0 if abs(v + 1) < 1e-15 else v))


_EYE = np.eye(4)


def _frame_or_none(T):
    """``None`` for the identity transform (or None), else the matrix as a float array."""
    T = _EYE if T is None else np.asarray(T, dtype=float)
    return None if (T == _EYE).all() else T


@dataclass(frozen=True, eq=False)
class Chain:
    """Per-link constants of a robot's kinematic chain.

    Attributes
    ----------
    modified, n : bool, int
        Modified (Craig) DH convention, else standard; the number of joints.
    steps : tuple of tuple
        Per link ``(revolute, a [m], cos alpha, sin alpha, d [m], theta [rad],
        cos theta, sin theta)``; the last two are used for prismatic joints.
    revolute, flipped, all_revolute : ndarray of int, ndarray of int, bool
        Indices of the revolute joints, and of those entering negated (``Link.flip``); all revolute.
    half_theta : ndarray, shape (r, 1) or None
        Half the revolute joints' DH ``theta`` offsets [rad] (None: all zero).
    base, tool : ndarray, shape (4, 4) or None
        World-from-base and frame-n-from-tool transforms [m] (None: identity).
    structure : tuple
        :func:`labkit.kinematics._program._chain_structure` for the tool point.
    programs : dict
        The tool point's programs bound to the chain's numbers (filled by
        :mod:`labkit.kinematics._forward` on first use).
    """

    modified: bool
    n: int
    steps: tuple
    revolute: np.ndarray
    all_revolute: bool
    flipped: np.ndarray
    half_theta: np.ndarray
    base: np.ndarray
    tool: np.ndarray
    structure: tuple = field(repr=False)
    programs: dict = field(default_factory=dict, repr=False)


@_per_robot
def chain(robot):
    """The chain constants of ``robot`` (cached per robot object).

    Parameters
    ----------
    robot : Robot

    Returns
    -------
    Chain
    """
    steps = tuple(_step(lk.is_revolute, lk.a, _clean(math.cos(lk.alpha)), _clean(math.sin(lk.alpha)), lk.d, lk.theta)
                  for lk in robot.links)
    return _assemble(robot.convention is Convention.MODIFIED, steps,
                     np.array([k for k, s in enumerate(steps) if s[0]], dtype=np.intp),
                     np.array([k for k, lk in enumerate(robot.links) if lk.flip], dtype=np.intp),
                     _frame_or_none(robot.base), _frame_or_none(robot.tool))


def _step(revolute, a, cos_alpha, sin_alpha, d, theta):
    """One link's entry of :attr:`Chain.steps`."""
    th = float(theta)
    return (bool(revolute), float(a), cos_alpha, sin_alpha, float(d), th, _clean(math.cos(th)), _clean(math.sin(th)))


def _assemble(modified, steps, rev, flipped, base, tool):
    """A :class:`Chain` from its steps, revolute and flipped joints and base and tool transforms (or None)."""
    half = np.array([[0.5 * steps[k][5]] for k in rev]).reshape(-1, 1)
    return Chain(
        modified=modified,
        n=len(steps),
        steps=steps,
        revolute=rev,
        all_revolute=rev.size == len(steps),
        flipped=flipped,
        half_theta=half if half.any() else None,
        base=base,
        tool=tool,
        structure=_chain_structure(steps, base, tool, None if tool is None else tool[:3, 3]),
    )


def _varied(c, theta=None, a=None, d=None, base_position=None, tool_position=None):
    """The chain ``c`` with DH columns [rad, m] or the base's or tool's translation [m] replaced (None: kept):
    number for number :func:`chain` of the robot with those values, its programs those of ``c``'s structure."""
    steps = []
    for i, step in enumerate(c.steps):
        rev, old_a, ca, sa, old_d, old_theta = step[:6]
        new = (old_a if a is None else a[i], old_d if d is None else d[i], old_theta if theta is None else theta[i])
        steps.append(step if new == (old_a, old_d, old_theta) else _step(rev, new[0], ca, sa, new[1], new[2]))
    frames = [c.base, c.tool]
    for k, position in enumerate((base_position, tool_position)):
        if position is not None:
            T = (_EYE if frames[k] is None else frames[k]).copy()
            T[:3, 3] = position
            frames[k] = _frame_or_none(T)
    return _assemble(c.modified, tuple(steps), c.revolute, c.flipped, *frames)


def prepare(robot, q, c=None):
    """Validate joint values: the chain (``c``, default the robot's), the effective ``q`` and the batch shape.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., n)
        Joint values [rad, m].
    c : Chain, optional

    Returns
    -------
    chain, q, lead : Chain, ndarray (N, n), tuple of int
        The chain, the effective joint values (flipped joints negated) [rad, m] and the batch shape.

    Raises
    ------
    ShapeError
        If ``q`` does not end in ``n`` or holds non-finite values.
    """
    c = chain(robot) if c is None else c
    n = c.n
    arr = q if type(q) is np.ndarray and q.dtype == np.float64 else None
    if arr is None or arr.shape[-1:] != (n,) or not np.isfinite(arr).all():
        arr = as_vector(q, n, "q")  # converts, or raises with what was expected and received
    lead = arr.shape[:-1]
    arr = arr.reshape(-1, n)
    if c.flipped.size:  # theta_i = -q_i + theta_i (d_i = -q_i + d_i) for a flipped joint
        arr = arr.copy()
        arr[:, c.flipped] *= -1.0
    return c, arr, lead
