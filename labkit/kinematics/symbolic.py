"""Symbolic kinematics with sympy: link transforms, the chain, position, Jacobian.

Every function returns simplified ``sympy.Matrix`` objects that a notebook
shows as LaTeX (``display(T)`` or :func:`latex`). Joint variables are sympy
symbols (``q1 .. qn`` by default, or names you pass); DH constants are exact
numbers - twists become rational multiples of ``pi`` and lengths exact
rationals in the chosen unit - or symbols (``lengths="symbolic"`` or a
``{name: value}`` mapping that names particular lengths, e.g. the ``L1`` and
``L2`` of a lab handout).

Conventions are those of :mod:`labkit.robot`:

* standard: ``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``; joint ``i``
  moves about/along ``z_{i-1}``;
* modified (Craig): ``A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``;
  joint ``i`` moves about/along ``z_i``.

The full chain is ``base @ A_1 @ ... @ A_n @ tool``, computed by the same DH
recursion as the numeric kinematics (:func:`labkit.kinematics._program.walk`,
run here on sympy expressions), so the LaTeX a student sees is the formula
the numbers come from. Simplification uses
``trigsimp`` entry by entry, which is quick for the 3-DOF arms of the lab
handouts; for a 6-DOF arm pass ``simplify=False`` and lambdify.
"""

from __future__ import annotations

from collections.abc import Mapping
from fractions import Fraction

import numpy as np

from labkit.exceptions import OptionError, ShapeError
from labkit.kinematics._program import PLAIN, walk
from labkit.robot.types import Convention
from labkit.validation import as_option, check_robot

__all__ = [
    "dh_matrix",
    "joint_symbols",
    "link_transforms",
    "forward_kinematics",
    "end_effector_position",
    "geometric_jacobian",
    "lambdify_joints",
    "latex",
]

_LENGTH_SCALE = {"m": 1.0, "mm": 1e3, "cm": 1e2}


def _sp():
    import sympy

    return sympy


def _exact(x, angle=False):
    """A float as an exact rational when it is one (denominator <= 10^6), an ``angle`` [rad] as a multiple of
    pi (denominator <= 360); else a sympy Float (sympy values pass unchanged)."""
    sp = _sp()
    if isinstance(x, sp.Basic):
        return x
    x = float(x)
    unit, most = (np.pi, 360) if angle else (1.0, 10**6)
    r = Fraction(x / unit).limit_denominator(most)
    if abs(float(r) * unit - x) <= 1e-12 * max(1.0, abs(x)):
        return sp.Rational(r.numerator, r.denominator) * (sp.pi if angle else 1)
    return sp.Float(x)


def dh_matrix(a, alpha, d, theta, convention="standard"):
    """Symbolic homogeneous transform of one DH row.

    Parameters
    ----------
    a, alpha, d, theta : sympy expression or float
        DH parameters (``a_{i-1}, alpha_{i-1}`` for the modified convention);
        floats are made exact (twists as multiples of pi).
    convention : {"standard", "modified"}

    Returns
    -------
    A : sympy.Matrix, shape (4, 4)

    Examples
    --------
    >>> import sympy as sp
    >>> th, a = sp.symbols("theta a")
    >>> dh_matrix(a, np.pi / 2, 0, th)
    Matrix([
    [cos(theta), 0,  sin(theta), a*cos(theta)],
    [sin(theta), 0, -cos(theta), a*sin(theta)],
    [         0, 1,           0,            0],
    [         0, 0,           0,            1]])
    """
    sp = _sp()
    conv = Convention(as_option(convention, [c.value for c in Convention], "convention"))
    a, d, alpha, theta = _exact(a), _exact(d), _exact(alpha, angle=True), _exact(theta, angle=True)
    identity = ((1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0, 0))
    step = (True, a, sp.cos(alpha), sp.sin(alpha), d, None, None)
    frames, _ = walk(PLAIN, conv is Convention.MODIFIED, identity, [step],
                     lambda j: (sp.cos(theta), sp.sin(theta)), None)
    return _matrix(frames[0])


def _matrix(frame):
    """A frame ``(x, y, z, origin)`` of 3-tuples as a sympy 4 x 4 matrix."""
    sp = _sp()
    cols = [list(c) for c in frame]
    return sp.Matrix([[cols[k][r] for k in range(4)] for r in range(3)] + [[0, 0, 0, 1]])


def _columns(M):
    """A sympy 4 x 4 matrix as a frame ``(x, y, z, origin)`` of 3-tuples."""
    return tuple(tuple(M[r, k] for r in range(3)) for k in range(4))


def joint_symbols(robot, q=None):
    """Sympy symbols for the joint variables.

    Parameters
    ----------
    robot : Robot
    q : sequence of str or sympy.Symbol, optional
        Names or symbols, one per joint; default ``q1 .. qn``.

    Returns
    -------
    tuple of sympy.Symbol
        Real symbols.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> joint_symbols(Robot.load("rpp_seed002"), ["theta1", "d2", "d3"])
    (theta1, d2, d3)
    """
    sp = _sp()
    if q is None:
        q = [f"q{i + 1}" for i in range(robot.n)]
    q = list(q)
    if len(q) != robot.n:
        raise ShapeError(f"expected {robot.n} joint symbols for {robot.name}, got {len(q)}")
    return tuple(s if isinstance(s, sp.Symbol) else sp.Symbol(str(s), real=True) for s in q)


def _length_mapper(lengths, unit):
    """Function (value_in_m, default_name) -> sympy length in ``unit``."""
    sp = _sp()
    scale = _LENGTH_SCALE[as_option(unit, _LENGTH_SCALE, "length_unit")]
    named = {}
    if isinstance(lengths, Mapping):
        named = {float(v): sp.Symbol(str(k), positive=True) for k, v in lengths.items() if float(v) != 0.0}
    elif lengths not in (None, "numeric", "symbolic"):
        raise OptionError(
            f"expected lengths None, 'numeric', 'symbolic' or a {{name: value [m]}} mapping, got {lengths!r}"
        )

    def f(value, name):
        value = float(value)
        if value == 0.0:
            return sp.Integer(0)
        for v, sym in named.items():
            if abs(abs(value) - v) <= 1e-12 * max(1.0, v):
                return sym if value > 0 else -sym
        if lengths == "symbolic":
            return sp.Symbol(name, real=True)
        return _exact(value * scale)

    return f


def link_transforms(robot, *, q=None, lengths=None, length_unit="m"):
    """The symbolic transform of every link, ``A_1 .. A_n``.

    Parameters
    ----------
    robot : Robot
    q : sequence of str or sympy.Symbol, optional
        Joint variables (see :func:`joint_symbols`).
    lengths : None, "symbolic" or mapping, optional
        ``None``: exact numbers; ``"symbolic"``: every non-zero ``a``/``d``
        becomes a symbol (``a_i``/``d_i``, or ``a_{i-1}`` in the modified
        convention); a mapping ``{"L1": 0.094}`` names lengths of that value
        [m] (sign kept).
    length_unit : {"m", "mm", "cm"}
        Unit of the exact numeric lengths (``"mm"`` to match hand derivations
        in millimetres).

    Returns
    -------
    tuple of sympy.Matrix, each shape (4, 4)

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> A = link_transforms(Robot.load("arduino_arm_3dof"), lengths={"L1": 0.094})
    >>> A[2]
    Matrix([
    [ cos(q3), -sin(q3),  0, L1],
    [-sin(q3), -cos(q3),  0,  0],
    [       0,        0, -1,  0],
    [       0,        0,  0,  1]])
    """
    return tuple(dh_matrix(a, alpha, d, theta, robot.convention)
                 for _, a, alpha, d, theta in _links(robot, q, _length_mapper(lengths, length_unit)))


def _links(robot, q, L):
    """Per link ``(revolute, a, alpha, d, theta)`` on sympy, the joint variable in ``theta`` or ``d``."""
    mod = check_robot(robot).convention is Convention.MODIFIED
    out = []
    for i, (lk, qi) in enumerate(zip(robot.links, joint_symbols(robot, q)), start=1):
        if lk.flip:  # the variable enters negated (Link.flip)
            qi = -qi
        a, theta = L(lk.a, f"a_{i - 1 if mod else i}"), _exact(lk.theta, angle=True)
        if lk.is_revolute:
            d, theta = L(lk.d, f"d_{i}"), qi + theta
        else:
            d = qi + L(lk.d, f"d0_{i}")
        out.append((lk.is_revolute, a, _exact(lk.alpha, angle=True), d, theta))
    return out


def _frame_matrix(T, L, prefix):
    """Symbolic 4x4 of a numeric base/tool transform (exact angles via RPY)."""
    sp = _sp()
    from labkit.rotations import rpy_from_matrix

    T = np.asarray(T, dtype=float)
    if np.allclose(T, np.eye(4), atol=0, rtol=0):
        return sp.eye(4)
    roll, pitch, yaw = (_exact(v, angle=True) for v in rpy_from_matrix(T[:3, :3]))
    R = sp.rot_axis3(-yaw) * sp.rot_axis2(-pitch) * sp.rot_axis1(-roll)  # sympy's rot_axis are transposed
    M = sp.eye(4)
    M[:3, :3] = R
    for k, axis in enumerate("xyz"):
        M[k, 3] = L(T[k, 3], f"{prefix}_{axis}")
    return M


def _simplify_matrix(M):
    return M.applyfunc(_sp().trigsimp)


def _walk(robot, q, lengths, length_unit):
    """The DH walk on sympy: frames 1..n, the joint axes, and the tool transform."""
    sp = _sp()
    L = _length_mapper(lengths, length_unit)
    steps = [(rev, a, sp.cos(alpha), sp.sin(alpha), d, sp.cos(theta), sp.sin(theta))
             for rev, a, alpha, d, theta in _links(robot, q, L)]
    trig = [step[5:] for step in steps if step[0]]
    base = _frame_matrix(robot.base, L, "base")
    frames, axes = walk(PLAIN, robot.convention is Convention.MODIFIED, _columns(base), steps, trig.__getitem__,
                        lambda i, d: d)
    last = _matrix(frames[-1]) if frames else base
    return last, axes, _frame_matrix(robot.tool, L, "t")


def forward_kinematics(robot, *, q=None, lengths=None, length_unit="m", simplify=True):
    """Symbolic ``world_from_tool`` transform ``base A_1 ... A_n tool``.

    Parameters
    ----------
    robot : Robot
    q, lengths, length_unit
        As in :func:`link_transforms` (the tool/base translations use
        ``t_x, t_y, t_z`` / ``base_x ..`` when ``lengths="symbolic"``).
    simplify : bool
        Apply trigonometric simplification to every entry.

    Returns
    -------
    T : sympy.Matrix, shape (4, 4)

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> T = forward_kinematics(Robot.load("planar3r_seed004"), lengths="symbolic")
    >>> T[0, 3]
    a_1*cos(q1) + a_2*cos(q1 + q2) + a_3*cos(q1 + q2 + q3)
    """
    last, _, tool = _walk(robot, q, lengths, length_unit)
    T = last * tool
    return _simplify_matrix(T) if simplify else T


def end_effector_position(robot, *, point=None, q=None, lengths=None, length_unit="m", simplify=True):
    """Symbolic position of the tool point (or of ``point`` given in tool coordinates).

    Parameters
    ----------
    robot : Robot
    point : sequence of 3 numbers or sympy expressions, optional
        Point in tool coordinates [m] (numbers are converted to ``length_unit``).
    q, lengths, length_unit, simplify
        As in :func:`forward_kinematics`.

    Returns
    -------
    p : sympy.Matrix, shape (3, 1)

    Examples
    --------
    Seed 000 (3-DOF arduino arm), with the seed's names for the lengths:

    >>> from labkit.robot import Robot
    >>> p = end_effector_position(Robot.load("arduino_arm_3dof"), lengths={"L1": 0.094, "L2": 0.180})
    >>> p[2]
    -L1*sin(q2) - L2*sin(q2 - q3)
    """
    T = forward_kinematics(robot, q=q, lengths=lengths, length_unit=length_unit, simplify=False)
    pt = _point(point, length_unit)
    p = (T * pt)[:3, :]
    return _simplify_matrix(p) if simplify else p


def _point(point, length_unit):
    sp = _sp()
    if point is None:
        return sp.Matrix([0, 0, 0, 1])
    if np.asarray(point, dtype=object).shape != (3,):
        raise ShapeError(f"expected point with 3 coordinates, got {point!r}")
    scale = _LENGTH_SCALE[length_unit]
    vals = [v if isinstance(v, sp.Basic) else _exact(float(v) * scale) for v in point]
    return sp.Matrix([*vals, 1])


def geometric_jacobian(robot, *, point=None, q=None, lengths=None, length_unit="m", simplify=True):
    """Symbolic geometric Jacobian of a point fixed to the tool frame (base axes).

    Column ``i`` is ``[z x (p - o); z]`` for a revolute and ``[z; 0]`` for a
    prismatic joint, with ``z``/``o`` the joint axis and a point on it
    (``z_{i-1}, o_{i-1}`` standard; ``z_i, o_i`` modified) - the same
    Jacobian as :func:`labkit.kinematics.jacobian`.

    Parameters
    ----------
    robot : Robot
    point : sequence of 3, optional
        Point in tool coordinates [m]; e.g. ``-tool translation`` for the
        origin of frame n.
    q, lengths, length_unit, simplify
        As in :func:`forward_kinematics`.

    Returns
    -------
    J : sympy.Matrix, shape (6, n)
        Rows ``vx, vy, vz, wx, wy, wz``.

    Examples
    --------
    Seed 002 problem 3 (RPP arm):

    >>> from labkit.robot import Robot
    >>> geometric_jacobian(Robot.load("rpp_seed002"), q=["theta1", "d2", "d3"])
    Matrix([
    [-d3*sin(theta1), 0, cos(theta1)],
    [ d3*cos(theta1), 0, sin(theta1)],
    [              0, 1,           0],
    [              0, 0,           0],
    [              0, 0,           0],
    [              1, 0,           0]])
    """
    sp = _sp()
    last, axes, tool = _walk(robot, q, lengths, length_unit)
    pe = (last * tool * _point(point, length_unit))[:3, 0]
    cols = []
    for (z, o), lk in zip(axes, robot.links):
        z, o = sp.Matrix(z), sp.Matrix(o)
        sign = -1 if lk.flip else 1  # d/dq = -d/dtheta for a flipped joint
        linear, angular = (z.cross(pe - o), z) if lk.is_revolute else (z, sp.zeros(3, 1))
        cols.append(sign * sp.Matrix.vstack(linear, angular))
    J = sp.Matrix.hstack(*cols)
    return _simplify_matrix(J) if simplify else J


def lambdify_joints(robot, expr, q=None):
    """A numpy function of the joint values for a symbolic expression.

    Parameters
    ----------
    robot : Robot
    expr : sympy expression or Matrix
        Built with the same joint symbols ``q`` and exact numeric lengths.
    q : sequence of str or sympy.Symbol, optional
        The joint symbols used in ``expr`` (default ``q1 .. qn``).

    Returns
    -------
    f : callable
        ``f(q_values)`` with ``q_values`` of shape (n,) returns a numpy array.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("planar3r_seed004")
    >>> f = lambdify_joints(arm, end_effector_position(arm))
    >>> np.round(f([0.0, 0.0, np.pi / 2]).ravel(), 3)
    array([0.35, 0.12, 0.  ])
    """
    sp = _sp()
    qs = joint_symbols(robot, q)
    fn = sp.lambdify(qs, expr, "numpy")

    def f(values):
        values = np.asarray(values, dtype=float)
        if values.shape != (robot.n,):
            raise ShapeError(f"expected q with shape ({robot.n},), got {values.shape}")
        return np.asarray(fn(*values), dtype=float)

    return f


def latex(expr):
    """LaTeX source of a sympy expression or matrix (for reports).

    Parameters
    ----------
    expr : sympy.Basic or sympy.MatrixBase
        Expression or matrix (e.g. from :func:`symbolic_fk`).

    Returns
    -------
    str
        ``sympy.latex(expr)``.

    Examples
    --------
    >>> import sympy as sp
    >>> latex(sp.Matrix([[sp.cos(sp.Symbol("q1"))]]))
    '\\\\left[\\\\begin{matrix}\\\\cos{\\\\left(q_{1} \\\\right)}\\\\end{matrix}\\\\right]'
    """
    return _sp().latex(expr)
