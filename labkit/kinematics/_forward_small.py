"""Forward kinematics and Jacobians for a handful of configurations, in plain Python (private).

For one configuration (a loop over poses, a widget callback, ``arm.move_to``)
the array bookkeeping of the batched kernels in
:mod:`labkit.kinematics._forward` costs more than the arithmetic. These
functions run the same chain on Python floats: the same formulas in the same
order (half-angle tangent, column updates, skipped zero terms), so both paths
agree to a few units in the last place. They take the :class:`Chain` and the
effective joint values from :func:`labkit.kinematics._chain.prepare` as nested
lists, and return flat lists of floats that the caller turns into one array.
"""

from __future__ import annotations

import math

_IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)


def _start(c):
    """Frame 0 as 12 floats: columns x, y, z of the rotation, then the origin."""
    if c.base is None:
        return _IDENTITY
    B = c.base
    return tuple(float(B[r, k]) for k in range(4) for r in range(3))


def walk(c, q, axes=None):
    """Frame n (before the tool) of one configuration.

    Parameters
    ----------
    c : Chain
        Chain constants.
    q : list of float, length n
        Effective joint values [rad, m].
    axes : list, optional
        If given, receives ``(z, o)`` per joint: axis direction and a point on
        it, as 3-tuples in world coordinates [1, m].

    Returns
    -------
    frame : tuple of float, length 12
        Columns x, y, z of the rotation, then the origin [m].
    """
    x0, y0, z0, x1, y1, z1, x2, y2, z2, px, py, pz = _start(c)
    tan = math.tan
    modified = c.modified
    for qi, (rev, a, ca, sa, d, th, cth, sth) in zip(q, c.steps):
        if rev:
            t = tan(qi * 0.5 + 0.5 * th) if th != 0.0 else tan(qi * 0.5)
            w = 2.0 / (t * t + 1.0)
            ct, st = w - 1.0, t * w
            dd = d
        else:
            ct, st = cth, sth
            dd = qi + d
        if modified:
            x1, y1, z1, x2, y2, z2 = (
                x1 * ca + x2 * sa, y1 * ca + y2 * sa, z1 * ca + z2 * sa,
                x2 * ca - x1 * sa, y2 * ca - y1 * sa, z2 * ca - z1 * sa,
            )
            if a != 0.0:
                px, py, pz = px + a * x0, py + a * y0, pz + a * z0
            if axes is not None:
                axes.append(((x2, y2, z2), (px, py, pz)))
            x0, y0, z0, x1, y1, z1 = (
                x0 * ct + x1 * st, y0 * ct + y1 * st, z0 * ct + z1 * st,
                x1 * ct - x0 * st, y1 * ct - y0 * st, z1 * ct - z0 * st,
            )
            if dd != 0.0 or not rev:
                px, py, pz = px + x2 * dd, py + y2 * dd, pz + z2 * dd
        else:
            if axes is not None:
                axes.append(((x2, y2, z2), (px, py, pz)))
            x0, y0, z0, x1, y1, z1 = (
                x0 * ct + x1 * st, y0 * ct + y1 * st, z0 * ct + z1 * st,
                x1 * ct - x0 * st, y1 * ct - y0 * st, z1 * ct - z0 * st,
            )
            if dd != 0.0 or not rev:
                px, py, pz = px + x2 * dd, py + y2 * dd, pz + z2 * dd
            if a != 0.0:
                px, py, pz = px + a * x0, py + a * y0, pz + a * z0
            x1, y1, z1, x2, y2, z2 = (
                x1 * ca + x2 * sa, y1 * ca + y2 * sa, z1 * ca + z2 * sa,
                x2 * ca - x1 * sa, y2 * ca - y1 * sa, z2 * ca - z1 * sa,
            )
    return x0, y0, z0, x1, y1, z1, x2, y2, z2, px, py, pz


def _combine(cols, w, start=None):
    """``start + sum_k cols[k] * w[k]`` on 3-tuples, skipping zero weights (batched order)."""
    acc = start
    for col, v in zip(cols, w):
        if v != 0.0:
            term = (col[0] * v, col[1] * v, col[2] * v)
            acc = term if acc is None else (acc[0] + term[0], acc[1] + term[1], acc[2] + term[2])
    return acc if acc is not None else (0.0, 0.0, 0.0)


def _tool(c, frame, off):
    """Apply the tool (and the point offset ``off``) to frame n: four 3-tuples."""
    cols = (frame[0:3], frame[3:6], frame[6:9])
    p = frame[9:12]
    if off is not None:
        p = _combine(cols, [float(v) for v in off], p)
    if c.tool is not None and not all(c.tool[r, k] == (r == k) for r in range(3) for k in range(3)):
        R = c.tool
        cols = tuple(_combine(cols, [float(R[r, k]) for r in range(3)]) for k in range(3))
    return cols[0], cols[1], cols[2], p


def _pose16(c0, c1, c2, p):
    return [c0[0], c1[0], c2[0], p[0], c0[1], c1[1], c2[1], p[1], c0[2], c1[2], c2[2], p[2],
            0.0, 0.0, 0.0, 1.0]


def fk(c, qs, off):
    """Tool poses of a few configurations.

    Parameters
    ----------
    c : Chain
        Chain constants.
    qs : list of list of float, shape (N, n)
        Effective joint values [rad, m].
    off : array_like, shape (3,) or None
        The tool origin in frame-n coordinates [m]; None for frame n's origin.

    Returns
    -------
    list of float, length 16 N
        The (N, 4, 4) poses in C order [m].
    """
    out = []
    for q in qs:
        out += _pose16(*_tool(c, walk(c, q), off))
    return out


def position(c, qs, off):
    """Positions of a point fixed to frame n, for a few configurations.

    Parameters
    ----------
    c : Chain
        Chain constants.
    qs : list of list of float, shape (N, n)
        Effective joint values [rad, m].
    off : array_like, shape (3,) or None
        The point in frame-n coordinates [m]; None for frame n's origin.

    Returns
    -------
    list of float, length 3 N
        The (N, 3) positions in C order [m].
    """
    w = None if off is None else [float(v) for v in off]
    out = []
    for q in qs:
        f = walk(c, q)
        out += f[9:12] if w is None else _combine((f[0:3], f[3:6], f[6:9]), w, f[9:12])
    return out


def fk_jacobian(c, qs, off, in_tool, want_pose):
    """Poses and geometric Jacobians of a few configurations.

    Parameters
    ----------
    c : Chain
        Chain constants.
    qs : list of list of float, shape (N, n)
        Effective joint values [rad, m].
    off : array_like, shape (3,) or None
        The point in frame-n coordinates [m]; None for frame n's origin.
    in_tool : bool
        Express the velocities in the tool frame instead of the base frame.
    want_pose : bool
        Also return the poses.

    Returns
    -------
    poses : list of float, length 16 N, or None
        The (N, 4, 4) poses in C order [m].
    jacobians : list of float, length 6 n N
        The (N, 6, n) Jacobians in C order [m/rad or 1].
    """
    n = c.n
    poses, jacs = ([] if want_pose else None), []
    for q in qs:
        axes = []
        t0, t1, t2, pe = _tool(c, walk(c, q, axes), off)
        rows = [[0.0] * n for _ in range(6)]
        for i, ((z, o), step) in enumerate(zip(axes, c.steps)):
            if step[0]:
                r = (pe[0] - o[0], pe[1] - o[1], pe[2] - o[2])
                rows[0][i] = z[1] * r[2] - z[2] * r[1]
                rows[1][i] = z[2] * r[0] - z[0] * r[2]
                rows[2][i] = z[0] * r[1] - z[1] * r[0]
                rows[3][i], rows[4][i], rows[5][i] = z
            else:
                rows[0][i], rows[1][i], rows[2][i] = z
        if in_tool:
            for part in (0, 3):
                V = rows[part:part + 3]
                rows[part:part + 3] = [
                    [V[0][i] * t[0] + V[1][i] * t[1] + V[2][i] * t[2] for i in range(n)] for t in (t0, t1, t2)
                ]
        for row in rows:
            jacs += row
        if want_pose:
            poses += _pose16(t0, t1, t2, pe)
    return poses, jacs
