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

from labkit.kinematics._chain import by_content
from labkit.kinematics._ik_solvers._registry import detect
from labkit.kinematics._ik_solvers._solve import solve as solve_family

#: snapping thresholds tried in turn, as fractions of the arm's length scale (sum of |a| + |d|)
SNAP_FRACTIONS = (1e-3, 1e-2, 3e-2)
#: largest twist-angle error snapped to a multiple of pi/2 [rad] (3 deg)
SNAP_ALPHA = np.radians(3.0)


def snapped(robot, fraction):
    """Copy of ``robot`` with small DH lengths set to 0 and near-right twists made exact.

    Parameters
    ----------
    robot : Robot
        The arm to idealise.
    fraction : float
        Lengths ``a``, ``d`` with ``|value| <= fraction * L`` become 0, where
        ``L`` is the sum of all ``|a| + |d|`` [m]; twists ``alpha`` within
        :data:`SNAP_ALPHA` of a multiple of pi/2 become that multiple.

    Returns
    -------
    Robot or None
        The idealised copy, or None when nothing changed.
    """
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


@by_content
def start_window(robot):
    """Where random starts of numeric IK are drawn: the limits, revolute joints within half a turn of 0.

    A revolute joint's window is its limits cut to ``c +- pi``, ``c`` the point of
    its range nearest 0 (0 when the range holds it): one turn, every angle
    once, whether the range is continuous (infinite), +-1e300 deg or a few
    degrees off 0. A prismatic joint's window is its limits (infinite ones as
    +-2 pi [m]). Cached by the robot's content.

    Parameters
    ----------
    robot : Robot
        The arm.

    Returns
    -------
    lo, hi : ndarray, shape (n,)
        The window's ends [rad, m].
    """
    lim, rev = robot.joint_limits, robot.is_revolute
    centre = np.clip(0.0, lim[:, 0], lim[:, 1])
    lo = np.where(rev, np.maximum(lim[:, 0], centre - np.pi), np.where(np.isfinite(lim[:, 0]), lim[:, 0], -2 * np.pi))
    hi = np.where(rev, np.minimum(lim[:, 1], centre + np.pi), np.where(np.isfinite(lim[:, 1]), lim[:, 1], 2 * np.pi))
    return lo, hi


@by_content
def near_family(robot):
    """The closed-form solver of the nearest idealised copy of ``robot`` (cached by content), or ``(None, None)``.

    A calibrated arm (small link offsets, twists a fraction of a degree off 90)
    has no closed form, but its idealised copy (:func:`snapped`, the smallest
    threshold of :data:`SNAP_FRACTIONS` that works) often has; its solutions
    land millimetres from the target, which Levenberg-Marquardt then polishes
    on the real arm in a few iterations.

    Parameters
    ----------
    robot : Robot
        An arm without a closed-form family of its own.

    Returns
    -------
    ideal : Robot or None
        The idealised copy.
    solver : object or None
        Its analytic solver.
    """
    result = (None, None)
    for fraction in SNAP_FRACTIONS:
        ideal = snapped(robot, fraction)
        if ideal is None:
            continue
        found, _ = detect(ideal)
        if found is not None:
            result = (ideal, found)
            break
    return result


@dataclasses.dataclass(frozen=True)
class Starts:
    """Ranked starting configurations of targets (:func:`analytic_seeds`).

    Attributes
    ----------
    all : ndarray, shape (N, m, n)
        Every start [rad, m], best first; rows of NaN after a target's last one.
    found : ndarray of bool, shape (N,)
        Which targets have a start (``all[:, 0]`` not NaN).
    """

    all: np.ndarray
    found: np.ndarray


def analytic_seeds(robot, kind, target):
    """Ranked starting configurations from a closed-form family of the robot or of its idealised copy, or None.

    When :func:`labkit.kinematics._ik_solvers._registry.detect` finds a solver for
    ``robot`` whose targets are of ``kind``, its branches that are reachable
    and inside the joint limits are the starts (so LM only polishes them).
    Otherwise the same is done with the solver of the nearest idealised copy
    of the robot (:func:`near_family`: small offsets removed), whose solutions
    are millimetres from the real ones; there every branch is a start, ranked:
    reachable and inside the limits first, then by how far it leaves the limits
    (clipped into them), then the copy's closest approaches to targets just out
    of its reach (the real arm may reach them). An attempt that stalls moves on
    to the next start; a target without any starts from a random configuration.

    Parameters
    ----------
    robot : Robot
        The arm to seed (with a closed form of its own, or near one).
    kind : {"position", "planar", "pose"}
        What the targets fix.
    target : ndarray, shape (N, 3) or (N, 4, 4)
        Targets [m, rad].

    Returns
    -------
    Starts or None
        None when no closed form applies.
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
