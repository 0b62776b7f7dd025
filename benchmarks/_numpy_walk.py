"""A generic numpy DH walk: the reference the compiled per-robot programs are measured against.

Before the programs of :mod:`labkit.kinematics._program`, labkit evaluated the
Jacobian by walking the chain on ``(3, m)`` blocks of a chunk of
configurations: every link's full column update (no constant folded), the
axes stored, then ``z_i x (p - o_i)`` per joint. That walk no longer exists in
labkit (the one DH recursion is ``_program.walk``); this module keeps an
equivalent, independent of labkit's code, so ``bench_kinematics.py`` can still
print the "generic walk" row (a reference like ``_numba_chain.py``, never
imported by labkit).
"""

from __future__ import annotations

import numpy as np

from labkit.robot import Convention

#: configurations per chunk (the (3, m) blocks of a chunk stay in the cache)
CHUNK = 8192


def jacobian(robot, q):
    """Base-frame geometric Jacobian (N, 6, n) of the tool point by the generic block walk."""
    q = np.asarray(q, dtype=float).reshape(-1, robot.n)
    N, n = q.shape
    out = np.empty((N, 6, n))
    tool = np.asarray(robot.tool, dtype=float)
    base = np.asarray(robot.base, dtype=float)
    links = robot.links
    modified = robot.convention is Convention.MODIFIED
    for s in range(0, N, CHUNK):
        qc = q[s:s + CHUNK]
        m = qc.shape[0]
        c0, c1, c2, p = (np.repeat(base[:3, k, None], m, axis=1) for k in range(4))
        Z, O = np.empty((3, n, m)), np.empty((3, n, m))
        for i, lk in enumerate(links):
            v = -qc[:, i] if lk.flip else qc[:, i]
            th = v + lk.theta if lk.is_revolute else np.full(m, lk.theta)
            d = lk.d if lk.is_revolute else v + lk.d
            ct, st = np.cos(th), np.sin(th)
            ca, sa = np.cos(lk.alpha), np.sin(lk.alpha)
            if modified:
                c1, c2 = c1 * ca + c2 * sa, c2 * ca - c1 * sa
                p = p + lk.a * c0
                Z[:, i], O[:, i] = c2, p
                c0, c1 = c0 * ct + c1 * st, c1 * ct - c0 * st
                p = p + c2 * d
            else:
                Z[:, i], O[:, i] = c2, p
                c0, c1 = c0 * ct + c1 * st, c1 * ct - c0 * st
                p = p + c2 * d + lk.a * c0
                c1, c2 = c1 * ca + c2 * sa, c2 * ca - c1 * sa
        pe = p + c0 * tool[0, 3] + c1 * tool[1, 3] + c2 * tool[2, 3]
        lin = np.cross(Z, pe[:, None, :] - O, axis=0)
        for i, lk in enumerate(links):
            sign = -1.0 if lk.flip else 1.0
            if lk.is_revolute:
                out[s:s + m, :3, i] = sign * lin[:, i].T
                out[s:s + m, 3:, i] = sign * Z[:, i].T
            else:
                out[s:s + m, :3, i] = sign * Z[:, i].T
                out[s:s + m, 3:, i] = 0.0
    return out
