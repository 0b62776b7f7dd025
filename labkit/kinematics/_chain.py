"""The kinematic chain's constants and where joint values enter it (private).

:func:`chain` turns a robot's DH rows into the per-link constants the
compiled programs of :mod:`labkit.kinematics._program` are built from, cached
per robot object (:func:`per_robot`, the keyed cache every per-robot constant
of the kinematics uses). :func:`prepare` is the one place joint values enter
the chain: it validates ``q`` and returns the effective joint values, shape
``(N, n)``, that every evaluator runs on.

Joint angles enter through the half-angle tangent ``t = tan(theta / 2)``:
``cos theta = 2 / (1 + t^2) - 1`` and ``sin theta = t * 2 / (1 + t^2)``. One
``tan`` per joint instead of a ``sin`` and a ``cos``: NumPy evaluates float64
``tan`` with SIMD but ``sin``/``cos`` one element at a time on AVX2 machines,
so this is about 5x cheaper, and it agrees with ``sin``/``cos`` to a few
units in the last place.
"""

from __future__ import annotations

import functools
import math
import weakref
from dataclasses import dataclass, field

import numpy as np

from labkit.exceptions import ShapeError
from labkit.kinematics._program import chain_structure
from labkit.robot.types import Convention
from labkit.validation import as_vector


def per_robot(func):
    """Cache ``func(robot)`` per robot object, in a keyed cache (``Robot`` stays plain frozen data).

    Entries die with the robot.

    Parameters
    ----------
    func : callable
        ``func(robot)``, a pure function of the robot.

    Returns
    -------
    callable
        The cached ``func``.
    """
    cache = weakref.WeakKeyDictionary()

    @functools.wraps(func)
    def cached(robot):
        try:
            return cache[robot]
        except KeyError:
            value = cache[robot] = func(robot)
            return value

    return cached


def by_content(func, size=64):
    """Cache ``func(robot)`` by what the robot is (its links, convention, base, tool and up direction).

    A freshly loaded robot or a copy with the same content finds the value of
    an earlier one; the most recent ``size`` contents are kept. Each robot
    object also remembers its own value (:func:`per_robot`).

    Parameters
    ----------
    func : callable
        ``func(robot)``, a pure function of that content.
    size : int
        Contents kept.

    Returns
    -------
    callable
        The cached ``func``.
    """
    cache = {}

    @per_robot
    @functools.wraps(func)
    def cached(robot):
        key = (robot.convention, robot.links, robot.base.tobytes(), robot.tool.tobytes(),
               np.asarray(robot.up, dtype=float).tobytes())
        try:
            return cache[key]
        except KeyError:
            if len(cache) >= size:
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
    modified : bool
        Modified (Craig) DH convention, else standard.
    n : int
        Number of joints.
    steps : tuple of tuple
        Per link ``(revolute, a [m], cos alpha, sin alpha, d [m], theta [rad],
        cos theta, sin theta)``; the last two are used for prismatic joints.
    revolute : ndarray of int, shape (r,)
        Indices of the revolute joints.
    all_revolute : bool
        Every joint is revolute (``revolute`` is ``0 .. n-1``).
    flipped : ndarray of int, shape (f,)
        Indices of the joints whose variable enters the chain negated
        (``Link.flip``); empty for most robots.
    half_theta : ndarray, shape (r, 1) or None
        Half the DH ``theta`` offsets of the revolute joints [rad]; ``None``
        when all are zero.
    base, tool : ndarray, shape (4, 4) or None
        World-from-base and frame-n-from-tool transforms [m]; ``None`` when
        the identity (skipped).
    structure : tuple
        The chain's structure and numbers for the tool point
        (:func:`labkit.kinematics._program.chain_structure`).
    programs : dict
        The programs of the tool point bound to the chain's numbers, by
        output and options (filled by :mod:`labkit.kinematics._forward` on
        first use).
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


@per_robot
def chain(robot):
    """The chain constants of ``robot`` (cached per robot object).

    Parameters
    ----------
    robot : Robot
        The arm whose DH rows are read.

    Returns
    -------
    Chain
        Its per-link constants.
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
        structure=chain_structure(steps, base, tool, None if tool is None else tool[:3, 3]),
    )


def varied(c, theta=None, a=None, d=None, base_position=None, tool_position=None):
    """The chain ``c`` with DH columns and the base's or tool's translation replaced.

    The same chain, number for number, as :func:`chain` of the robot with
    those values; its programs are found in the cache of ``c``'s structure
    (unless a value becomes 0 or +-1), so nothing is compiled.

    Parameters
    ----------
    c : Chain
        The robot's chain.
    theta, a, d : sequence of float, length n, optional
        DH columns [rad, m] (None: keep).
    base_position, tool_position : sequence of float, length 3, optional
        Translation of the base (world-from-frame-0) and tool (frame-n-from-tool) transforms [m].

    Returns
    -------
    Chain
    """
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
    """Validate joint values and return the chain, the effective ``q`` and the batch shape.

    The one place where joint values enter the chain: both FK kernels run on
    the array this returns.

    Parameters
    ----------
    robot : Robot
        The arm.
    q : array_like, shape (..., n)
        Joint values [rad for revolute, m for prismatic joints].
    c : Chain, optional
        The chain to use (default the robot's).

    Returns
    -------
    chain : Chain
        The robot's chain constants (or ``c``).
    q : ndarray, shape (N, n)
        Effective joint values [rad, m], batch dimensions flattened.
    lead : tuple of int
        The batch shape ``...`` of the input.

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


def half_angle_trig(t, cos_out=None):
    """Cosine and sine from half-angle tangents, in place of a ``sin`` and a ``cos``.

    Parameters
    ----------
    t : ndarray
        ``tan(theta / 2)``; overwritten with ``sin theta``.
    cos_out : ndarray, optional
        Array of ``t``'s shape to write the cosine into (default: a new one).

    Returns
    -------
    cos, sin : ndarray
        Same shape as ``t``; ``sin`` is ``t`` itself.
    """
    w = np.multiply(t, t, out=cos_out)
    w += 1.0
    np.divide(2.0, w, out=w)
    t *= w
    w -= 1.0
    return w, t


def check_out(out, shape, name="out"):
    """Validate a caller's output array (float64, C-contiguous, exact shape).

    Parameters
    ----------
    out : ndarray
        The array to write into.
    shape : tuple of int
        Required shape.
    name : str
        Argument name used in the error message.

    Returns
    -------
    ndarray
        ``out`` itself.

    Raises
    ------
    ShapeError
        With what was expected and what was received.
    """
    if not isinstance(out, np.ndarray) or out.dtype != np.float64 or not out.flags.c_contiguous \
            or not out.flags.writeable or out.shape != tuple(shape):
        got = f"{type(out).__name__} {getattr(out, 'dtype', '')} {getattr(out, 'shape', '')}".strip()
        raise ShapeError(
            f"expected {name} as a writeable C-contiguous float64 array of shape {tuple(shape)}, got {got}"
        )
    return out
