"""The board's motion checks of a ``SEG``/``MOVE`` (``docs/protocol.md`` 4.3), step for step in integers.

The firmware (``lk_check`` in ``firmware/labkit_arm/labkit_core.c``), the virtual board and the host
all decide with this algorithm on integers, so they accept and refuse exactly the same segments:

- On ``0 <= s <= 1`` a polynomial lies within the hull of its Bernstein coefficients, and the first
  and last of them are its end values. The coefficients of ``q`` are taken times ``K`` (3 for cubics,
  10 for quintics) so that they are integers; those of ``dq/ds`` and ``d2q/ds2`` are their first and
  second differences (times ``K / n`` and ``K / (n (n - 1))``).
- The hull inside the limit proves the check; an end value outside refutes it (exact, 64-bit products).
- Otherwise the polynomial is halved at ``s = 1/2`` (de Casteljau) at most :data:`SUB_DEPTH` times,
  left half first, in integers scaled to 29 bits with every average rounded down: a stored coefficient
  never exceeds the true one and falls short of it by less than ``e = 1 + level m`` (``e = 0`` while
  the halvings are still exact). A piece passes when ``-lim <= c`` and ``c + e <= lim`` for all its
  coefficients ``c``; the check fails when an end value is proven outside or when a piece is still
  undecided after :data:`SUB_DEPTH` halvings (then the segment is within about ``4^-6 / 8`` of the
  limit relative to its curvature, and refused: the check is exact or conservative, never lenient).

Examples
--------
>>> segment_speed_ok([4500, 0, 13500, -9000], 1000, 30000, 150000)  # 45 -> 90 deg in 1 s
True
>>> segment_speed_ok([9000, 0, 10200, -6400], 90, 60000, 0)  # peak 5418.75 > 5400 cdeg, between s = k/16
False
>>> segment_position_ok([9000, 28000, -30000, 1000], 0, 18000)  # hull leaves 0..18000, the curve does not
True
"""

from __future__ import annotations

__all__ = []

#: the most halvings of an undecided polynomial (firmware ``LK_SUB_DEPTH``)
SUB_DEPTH = 6
#: Bernstein weights ``K C(k, i) / C(n, i)``, rows ``k = 0..n``, with ``K`` = 3 (cubics) and 10 (quintics)
_BERNSTEIN = {
    3: (3, ((3,), (3, 1), (3, 2, 1), (3, 3, 3, 3))),
    5: (10, ((10,), (10, 2), (10, 4, 1), (10, 6, 3, 1), (10, 8, 6, 4, 2), (10, 10, 10, 10, 10, 10))),
}


def _subdivide(p, lim, sh):
    """Halve the scaled coefficients ``p`` until ``|p| <= lim`` is proven (True) or refuted (False)."""
    m = len(p) - 1
    pending = []
    level = 0
    while True:
        e = 1 + level * m if sh < 0 or level * m > sh else 0
        if max(p[0], p[m]) > lim or min(p[0], p[m]) + e < -lim:
            return False
        if all(-lim <= c and c + e <= lim for c in p):
            if not pending:
                return True
            p, level = pending.pop()
            continue
        if level == SUB_DEPTH:
            return False
        r = list(p)
        left = [r[0]]
        for i in range(1, m + 1):
            for k in range(m - i + 1):
                r[k] = (r[k] + r[k + 1]) >> 1
            left.append(r[0])
        level += 1
        pending.append((r, level))
        p = left


def check(coef, kind, lo=0, hi=0, x=0, y=0):
    """One joint's motion check on ``0 <= s <= 1``, exactly as the board decides it.

    Parameters
    ----------
    coef : sequence of int, shape (4,) or (6,)
        Coefficients ``c_0 .. c_n`` [cdeg] of ``q(s)`` over normalised time.
    kind : {0, 1, 2}
        0: ``lo <= q(s) <= hi``; 1: ``|dq/ds| <= x y / 1000``; 2: ``|d2q/ds2| <= x y / 10^6``.
    lo, hi : int
        Position bounds [cdeg] (``kind`` 0).
    x, y : int
        The limit ``x y / 1000`` or ``x y / 10^6`` as two factors (a limit and the duration, or its square).

    Returns
    -------
    bool
        True if proven, False if refuted or undecided.
    """
    order = len(coef) - 1
    kk, rows = _BERNSTEIN[order]
    c = [int(v) for v in coef]
    b = [sum(w * c[i] for i, w in enumerate(row)) for row in rows]
    q = 1
    if kind == 0:
        b = [2 * v - kk * (lo + hi) for v in b]
        x, y = hi - lo, 1
    else:
        for _ in range(kind):
            b = [b[k + 1] - b[k] for k in range(len(b) - 1)]
        q = 1000 * order if kind == 1 else 1_000_000 * order * (order - 1)
    x *= kk
    big = max(abs(v) for v in b)
    if big * q <= x * y:
        return True
    if max(abs(b[0]), abs(b[-1])) * q > x * y:
        return False
    sh = 0
    while big >= 1 << 29:
        big >>= 1
        sh -= 1
    while big < 1 << 28:
        big <<= 1
        sh += 1
    b = [v << sh if sh >= 0 else v >> -sh for v in b]
    n = x * y << sh if sh >= 0 else x * y >> -sh
    return _subdivide(b, n // q, sh)


def segment_position_ok(coef, lo, hi):
    """Whether one joint's segment stays within ``lo..hi`` [cdeg] for ``0 <= s <= 1`` (the board's check).

    Parameters
    ----------
    coef : sequence of int, shape (4,) or (6,)
        Coefficients [cdeg] over normalised time.
    lo, hi : int
        The joint's feasible range (limits and servo range) [cdeg].

    Returns
    -------
    bool
    """
    return check(coef, 0, lo=int(lo), hi=int(hi))


def segment_speed_ok(coef, dur_ms, vmax, amax):
    """Whether one joint's segment keeps to the speed and acceleration limits (the board's check).

    ``|dq/ds| <= vmax T`` and ``|d2q/ds2| <= amax T^2`` for ``0 <= s <= 1``, ``T = dur_ms / 1000`` s,
    decided by :func:`check` exactly as the firmware decides it.

    Parameters
    ----------
    coef : sequence of int, shape (4,) or (6,)
        Coefficients [cdeg] over normalised time ``s = t / T``.
    dur_ms : int
        Segment duration ``T`` [ms].
    vmax : int
        Speed limit [cdeg/s]; 0 leaves the speed unchecked.
    amax : int
        Acceleration limit [cdeg/s^2]; 0 leaves the acceleration unchecked.

    Returns
    -------
    bool
    """
    dur = int(dur_ms)
    return ((not vmax or check(coef, 1, x=int(vmax), y=dur))
            and (not amax or check(coef, 2, x=int(amax), y=dur * dur)))
