"""Where numeric IK starts (private): closed-form branches, of the robot or of its idealised copy, ranked.

:func:`analytic_seeds` gives :func:`labkit.kinematics._ik_solvers._numeric.solve` its
starts: the branches of the robot's own closed-form family, or of the family
of its idealised copy (:func:`near_family`: small offsets removed, twists made
right angles), ranked by one rule: reachable and inside the limits first, then
by how far they leave them.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from labkit.kinematics._chain import _by_content
from labkit.kinematics._ik_solvers._registry import detect
from labkit.kinematics._ik_solvers._solve import solve as solve_family

#: snapping thresholds tried in turn, as fractions of the arm's length scale (sum of |a| + |d|)
SNAP_FRACTIONS = (1e-3, 1e-2, 3e-2)
#: largest twist-angle error _snapped to a multiple of pi/2 [rad] (3 deg)
SNAP_ALPHA = np.radians(3.0)


def _snapped(robot, fraction):
    """Copy of ``robot`` with DH lengths up to ``fraction`` of the sum of all ``|a| + |d|`` set to 0 and twists
    within :data:`SNAP_ALPHA` of a multiple of pi/2 made that multiple; None when nothing changed."""
    scale = sum(abs(link.a) + abs(link.d) for link in robot.links)
    links, changed = [], False
    for link in robot.links:
        a = 0.0 if abs(link.a) <= fraction * scale else link.a
        d = 0.0 if abs(link.d) <= fraction * scale else link.d
        right = round(link.alpha / (0.5 * np.pi)) * 0.5 * np.pi
        alpha = right if abs(link.alpha - right) <= SNAP_ALPHA else link.alpha
        if (a, d, alpha) != (link.a, link.d, link.alpha):
            changed = True
            link = dataclasses.replace(link, a=a, d=d, alpha=alpha)
        links.append(link)
    return robot.replace(links=tuple(links)) if changed else None


@_by_content
def start_window(robot):
    """Where random starts of numeric IK are drawn [rad, m] (cached by content).

    A revolute joint's window is its limits cut to ``c +- pi``, ``c`` the point of its range
    nearest 0: one turn, whether the range is infinite, +-1e300 deg or a few degrees off 0. A
    prismatic joint's window is its limits (infinite ones as +-2 pi [m]).

    Parameters
    ----------
    robot : Robot

    Returns
    -------
    lo, hi : ndarray, shape (n,)
    """
    lim, rev = robot.joint_limits, robot.is_revolute
    centre = np.clip(0.0, lim[:, 0], lim[:, 1])
    lo = np.where(rev, np.maximum(lim[:, 0], centre - np.pi), np.where(np.isfinite(lim[:, 0]), lim[:, 0], -2 * np.pi))
    hi = np.where(rev, np.minimum(lim[:, 1], centre + np.pi), np.where(np.isfinite(lim[:, 1]), lim[:, 1], 2 * np.pi))
    return lo, hi


@_by_content
def near_family(robot):
    """The nearest idealised copy of ``robot`` that has a closed form, and that family, or ``(None, None)``.

    A calibrated arm (small link offsets, twists a fraction of a degree off 90) has no closed form,
    but its idealised copy (:func:`_snapped`, the smallest of :data:`SNAP_FRACTIONS` that works)
    often has; its solutions land millimetres from the target, for LM to polish. Cached by content.

    Parameters
    ----------
    robot : Robot

    Returns
    -------
    ideal, solver : Robot or None, Family or None
    """
    result = (None, None)
    for fraction in SNAP_FRACTIONS:
        ideal = _snapped(robot, fraction)
        if ideal is None:
            continue
        found, _ = detect(ideal)
        if found is not None:
            result = (ideal, found)
            break
    return result


@dataclasses.dataclass(frozen=True)
class Starts:
    """Ranked starts (N, m, n) [rad, m] of targets, best first, rows of NaN after a target's last one
    (``all``), and which targets have one (``found``, shape (N,))."""

    all: np.ndarray
    found: np.ndarray


def analytic_seeds(robot, kind, target):
    """Ranked starts from the closed form of the robot or of its idealised copy, or None when none applies.

    With the robot's own family (for targets of ``kind``) the starts are its branches that are
    reachable and inside the limits (LM only polishes them). With the idealised copy's
    (:func:`near_family`) every branch is a start: reachable and inside the limits first, then by
    how far it leaves them (clipped into them), then the copy's closest approaches to targets just
    out of its reach (the real arm may reach them).

    Parameters
    ----------
    robot : Robot
    kind : {"position", "planar", "pose"}
    target : ndarray, shape (N, 3) or (N, 4, 4)
        Targets [m, rad].

    Returns
    -------
    Starts or None
    """
    found, _ = detect(robot)
    exact = found is not None  # the robot's own family (else its idealised copy's)
    if not exact:
        _, found = near_family(robot)
    if found is None or found.kind != kind:
        return None
    q, reach, _, _ = solve_family(robot, found, target)  # the idealised copy has the robot's joints and limits
    lim = robot.joint_limits
    inside = np.clip(q, lim[:, 0], lim[:, 1])
    rank = np.abs(q - inside).sum(axis=-1)  # how far each branch leaves the limits
    if exact:
        rank = np.where(reach & (rank == 0.0), 0.0, np.inf)
    else:
        rank = np.where(reach, rank, rank + 1e3)
    order = rank.argsort(axis=1, kind="stable")
    rows = np.arange(q.shape[0])[:, None]
    seeds = inside[rows, order]
    seeds[np.isinf(rank[rows, order])] = np.nan
    return Starts(seeds, ~np.isnan(seeds[:, 0, 0]))
