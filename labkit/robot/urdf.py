"""URDF import: a serial chain of a URDF as an equivalent modified-DH :class:`~labkit.robot.Robot`.

The URDF is parsed with `yourdfpy <https://github.com/clemense/yourdfpy>`_ (imported
when a file is read). The joints from ``base_link`` down to ``tip_link`` are taken at
``q = 0``: fixed joints are folded into the geometry, and every revolute, continuous
or prismatic joint contributes its axis line (direction and a point, in
``base_link`` coordinates). Those lines are turned into modified (Craig) DH rows by
the usual construction: frame ``i`` has ``z_i`` on axis ``i`` (in the URDF axis
direction, so ``q`` keeps its sign) and ``x_i`` along the common normal to axis
``i + 1`` (for parallel axes, the normal through the point where ``x_{i-1}`` meets
axis ``i``; for intersecting ones ``z_i x z_{i+1}``). Frame 1 at ``q = 0`` becomes the
robot's ``base`` and the ``tip_link`` frame seen from the last DH frame its ``tool``,
so forward kinematics equals the URDF's own chain for every ``q`` (rounding only).

The ``<inertial>`` of each link moved by joint i, together with every link it carries through
fixed joints (and side branches off the chain, at their zero position), becomes that joint's
``Link.inertial``, lumped by the parallel-axis theorem into DH frame i: what roboticstoolbox's
URDF import gets wrong when a chain has fixed joints.

Only numpy and :mod:`labkit.rotations` are used here (layer 3): no kinematics.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from labkit.exceptions import RobotError, needs_extra
from labkit.robot._inertia import LinkInertia, lump
from labkit.robot.types import Convention, JointType, Link

__all__ = ["urdf_fields"]

_MOVING = {"revolute": JointType.REVOLUTE, "continuous": JointType.REVOLUTE, "prismatic": JointType.PRISMATIC}
#: axes closer than this to parallel (but not within parallel_tol) make the common normal so far
#: away that DH loses the 1e-12 accuracy: they are an error naming the joint
_NEAR_PARALLEL = 1e-4


def _read(path):
    with needs_extra("urdf"):
        import yourdfpy  # heavy (lxml, trimesh): only when a URDF is read
    import logging

    p = Path(os.fspath(path))
    if not p.is_file():
        raise RobotError(f"{p}: no such URDF file", "<file>")
    log = logging.getLogger("yourdfpy")
    level = log.level
    log.setLevel(logging.CRITICAL)  # it logs and retries on malformed XML; we raise instead
    try:
        urdf = yourdfpy.URDF.load(str(p), build_scene_graph=False, load_meshes=False,
                                  build_collision_scene_graph=False, load_collision_meshes=False)
    except Exception as exc:  # noqa: BLE001 - any parser failure becomes one clear error
        raise RobotError(f"{p}: not a readable URDF file: {exc}", "<file>") from None
    finally:
        log.setLevel(level)
    robot = urdf.robot
    if robot is None or not robot.links:
        raise RobotError(f"{p}: not a readable URDF file: no <robot> with links found", "<file>")
    return p, robot


def _chain(path, robot, base_link, tip_link):
    """Joints from base_link down to tip_link (in order) and the two link names."""
    by_child = {j.child: j for j in robot.joints}
    parents = {j.parent for j in robot.joints}
    links = [lk.name for lk in robot.links]
    roots = [nm for nm in links if nm not in by_child]
    for name, value in (("base_link", base_link), ("tip_link", tip_link)):
        if value is not None and value not in links:
            raise RobotError(f"{path}: {name} {value!r} is not a link; expected one of {links}", name)
    if base_link is None:
        if len(roots) != 1:
            raise RobotError(f"{path}: expected one root link, got {roots}; give base_link", "base_link")
        base_link = roots[0]
    if tip_link is None:
        leaves = [nm for nm in links if nm not in parents]
        below = [nm for nm in leaves if _is_below(nm, base_link, by_child)]
        depth = {nm: _moving_depth(nm, base_link, by_child) for nm in below}
        deepest = [nm for nm in below if depth[nm] == max(depth.values(), default=0)]
        if len(deepest) != 1:
            raise RobotError(
                f"{path}: expected one leaf link with the most moving joints below {base_link!r}, got "
                f"{deepest}; give tip_link", "tip_link",
            )
        tip_link = deepest[0]
    joints = []
    link = tip_link
    while link != base_link:
        if link not in by_child:
            raise RobotError(f"{path}: tip_link {tip_link!r} is not below base_link {base_link!r}", "tip_link")
        j = by_child[link]
        joints.append(j)
        link = j.parent
    return joints[::-1], base_link, tip_link


def _moving_depth(link, base, by_child):
    """Number of non-fixed joints from ``base`` down to ``link``."""
    count = 0
    while link != base and link in by_child:
        count += by_child[link].type != "fixed"
        link = by_child[link].parent
    return count


def _is_below(link, base, by_child):
    while link in by_child:
        link = by_child[link].parent
        if link == base:
            return True
    return link == base


def _lines(path, joints):
    """Axis lines (unit direction, point) of the moving joints at q = 0 and the tip pose, in base coordinates."""
    T = np.eye(4)
    lines, moving = [], []
    for j in joints:
        origin = np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=float)
        T = T @ origin
        if j.type == "fixed":
            continue
        if j.type not in _MOVING:
            raise RobotError(
                f"{path}: joint {j.name!r} is {j.type!r}; expected revolute, continuous, prismatic or fixed "
                f"joints on the chain", f"joint {j.name}",
            )
        if j.mimic is not None:
            raise RobotError(f"{path}: joint {j.name!r} mimics {j.mimic.joint!r}; mimic joints are not supported",
                             f"joint {j.name}")
        axis = np.array([1.0, 0.0, 0.0]) if j.axis is None else np.asarray(j.axis, dtype=float)
        norm = float(np.linalg.norm(axis))
        if not np.isfinite(norm) or norm < 1e-9:
            raise RobotError(f"{path}: joint {j.name!r} has axis {axis.tolist()}; expected a non-zero direction",
                             f"joint {j.name}")
        lines.append((T[:3, :3] @ (axis / norm), T[:3, 3].copy()))
        moving.append(j)
    if not moving:
        raise RobotError(f"{path}: no revolute or prismatic joint between the links", "joint")
    return lines, moving, T


def _inertials(robot, base_link, moving, frames):
    """Each moving joint's link, with every link rigidly carried by it, lumped in its DH frame (or None).

    A URDF link belongs to the nearest moving chain joint above it: the links hung below it by
    fixed joints (a flange, a tool, a sensor) and any side branch off the chain (carried at its
    zero position) are added to it by the parallel-axis theorem, in DH frame i at ``q = 0``.
    Links fixed to ``base_link`` carry no load on any joint and are left out.
    """
    by_child = {j.child: j for j in robot.joints}
    owner = {j.child: i for i, j in enumerate(moving)}
    poses = {base_link: np.eye(4)}

    def pose(link):  # base_link -> link at q = 0 (None if not below base_link)
        if link not in poses:
            j = by_child.get(link)
            above = None if j is None else pose(j.parent)
            poses[link] = None if above is None else above @ (np.eye(4) if j.origin is None else
                                                             np.asarray(j.origin, dtype=float))
        return poses[link]

    def joint_of(link):  # index of the nearest moving chain joint above link, or None
        while link != base_link and link in by_child:
            if link in owner:
                return owner[link]
            link = by_child[link].parent
        return None

    groups = {}
    for lk in robot.links:
        ine = lk.inertial
        if ine is None or ine.mass is None or (ine.mass == 0 and ine.inertia is None):
            continue
        i = joint_of(lk.name)
        if i is None or pose(lk.name) is None:
            continue
        at = pose(lk.name) @ (np.eye(4) if ine.origin is None else np.asarray(ine.origin, dtype=float))
        tensor = np.zeros((3, 3)) if ine.inertia is None else np.asarray(ine.inertia, dtype=float)
        body = LinkInertia.from_matrix(float(ine.mass), np.zeros(3), tensor)
        groups.setdefault(i, []).append((body, np.linalg.inv(_frame_matrix(*frames[i])) @ at))
    return [lump(groups[i]) if i in groups else None for i in range(len(moving))]


def _perpendicular(z, hint):
    """A unit vector perpendicular to z, as close to ``hint`` as possible."""
    if hint is not None:
        v = hint - z * (hint @ z)
        n = np.linalg.norm(v)
        if n > 1e-9:
            return v / n
    h = np.eye(3)[int(np.argmin(np.abs(z)))]  # the least aligned world axis: never parallel to z
    v = h - z * (h @ z)
    return v / np.linalg.norm(v)


def _dh_frames(path, lines, names, parallel_tol):
    """Modified-DH frames (x, z, origin) on the axis lines, and the hit points of x_{i-1} on axis i."""
    n = len(lines)
    frames, hits = [], [lines[0][1]]
    x_prev = None
    for i in range(n):
        z, p = lines[i]
        hit = hits[i]
        if i == n - 1:
            o, x = hit, _perpendicular(z, x_prev)
        else:
            z2, p2 = lines[i + 1]
            cross = np.cross(z, z2)
            angle = math.atan2(float(np.linalg.norm(cross)), abs(float(z @ z2)))
            if parallel_tol <= angle < _NEAR_PARALLEL:
                gap = float(np.linalg.norm((p2 - p) - z * ((p2 - p) @ z)))
                raise RobotError(
                    f"{path}: joint {names[i + 1]!r}: its axis is {angle:.3g} rad from parallel to the axis of "
                    f"{names[i]!r}: too close to parallel for an exact DH chain (their common normal lies about "
                    f"{gap / max(angle, 1e-300):.3g} m away) and not within parallel_tol = {parallel_tol:g} rad; "
                    f"pass parallel_tol > {angle:.3g} to treat the axes as parallel (forward kinematics then "
                    f"differs from the URDF by about the angle times the reach)", f"joint {names[i + 1]}",
                )
            if angle >= _NEAR_PARALLEL:  # skew or intersecting: the common normal
                w = p - p2
                b = z @ z2
                den = 1.0 - b * b
                t1 = (b * (z2 @ w) - (z @ w)) / den
                t2 = ((z2 @ w) - b * (z @ w)) / den
                c1, c2 = p + t1 * z, p2 + t2 * z2
                o = c1
                gap = c2 - c1
                x = gap / np.linalg.norm(gap) if np.linalg.norm(gap) > 1e-12 else cross / np.linalg.norm(cross)
                hits.append(c2)
            else:  # parallel: the normal through the hit point of x_{i-1}
                o = hit
                d = (p2 - o) - z * ((p2 - o) @ z)
                x = d / np.linalg.norm(d) if np.linalg.norm(d) > 1e-12 else _perpendicular(z, x_prev)
                hits.append(o + d)
        frames.append((x, z, o))
        x_prev = x
    return frames, hits


def _frame_matrix(x, z, o):
    F = np.eye(4)
    F[:3, 0], F[:3, 1], F[:3, 2], F[:3, 3] = x, np.cross(z, x), z, o
    return F


def urdf_fields(path, *, base_link=None, tip_link=None, name=None, parallel_tol=1e-12):
    """Read a URDF chain and return the fields of an equivalent modified-DH :class:`~labkit.robot.Robot`.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.urdf`` file (meshes are not loaded).
    base_link, tip_link : str, optional
        Ends of the chain; default the root link and the leaf below it with the
        most moving joints on the way (it must be unique).
    name : str, optional
        Robot name; default the URDF's ``<robot name>``.
    parallel_tol : float
        Consecutive axes within this angle [rad] are treated as parallel. Axes
        between ``parallel_tol`` and 1e-4 rad from parallel are an error naming the
        joint (exact DH would put their common normal far away and lose accuracy);
        a larger ``parallel_tol`` accepts them with an FK error of about angle x reach.

    Returns
    -------
    dict
        Keyword arguments of :class:`~labkit.robot.Robot`: ``links`` (one per
        revolute/continuous/prismatic joint, named as in the URDF, limits and
        ``max_velocity`` from ``<limit>``; continuous joints get (-pi, pi); ``inertial`` from
        the ``<inertial>`` of the links each joint moves, fixed joints lumped),
        ``convention`` (modified), ``base`` (``base_link`` -> DH frame 1 at
        ``q = 0``) and ``tool`` (last DH frame -> ``tip_link``) [m, rad].

    Raises
    ------
    RobotError
        Unreadable file, unknown or unrelated links, a joint that is not
        revolute/continuous/prismatic/fixed, a mimic joint, a zero axis, an axis
        nearly but not exactly parallel to the previous one, or limits with
        ``lower >= upper`` (the message names the joint).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> text = '''<robot name="two"><link name="a"/><link name="b"/><link name="c"/>
    ...   <joint name="j1" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint>
    ...   <joint name="j2" type="revolute"><parent link="b"/><child link="c"/>
    ...     <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="2"/>
    ...   </joint></robot>'''
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = pathlib.Path(d) / "two.urdf"
    ...     _ = p.write_text(text)
    ...     fields = urdf_fields(p)
    >>> [(lk.name, round(lk.a, 3)) for lk in fields["links"]], fields["links"][1].max_velocity
    ([('j1', 0.0), ('j2', 0.3)], 2.0)
    """
    p, robot = _read(path)
    joints, base_link, tip_link = _chain(p, robot, base_link, tip_link)
    lines, moving, T_tip = _lines(p, joints)
    frames, hits = _dh_frames(p, lines, [j.name for j in moving], parallel_tol)
    inertials = _inertials(robot, base_link, moving, frames)
    links = []
    for i, (j, (x, z, o)) in enumerate(zip(moving, frames)):
        if i == 0:
            a = alpha = d = theta = 0.0
        else:
            xp, zp, op = frames[i - 1]
            a = float((hits[i] - op) @ xp)
            alpha = math.atan2(float(np.cross(zp, z) @ xp), float(zp @ z))
            d = float((o - hits[i]) @ z)
            theta = math.atan2(float(np.cross(xp, x) @ z), float(xp @ x))
        jt = _MOVING[j.type]
        lim = j.limit
        if j.type == "continuous":
            limits = (-math.pi, math.pi)
        else:
            lo = None if lim is None else lim.lower
            hi = None if lim is None else lim.upper
            if lo is None or hi is None or not lo < hi:
                raise RobotError(
                    f"{p}: joint {j.name!r}: expected <limit lower < upper>, got lower={lo!r}, upper={hi!r}",
                    f"joint {j.name}",
                )
            limits = (float(lo), float(hi))
        v = float(lim.velocity) if lim is not None and lim.velocity is not None and lim.velocity > 0 else None
        links.append(Link(a=a, alpha=alpha, d=d, theta=theta, joint_type=jt, limits=limits, name=j.name,
                          max_velocity=v, inertial=inertials[i]))
    base = _frame_matrix(*frames[0])
    tool = np.linalg.inv(_frame_matrix(*frames[-1])) @ T_tip
    tool[3] = [0.0, 0.0, 0.0, 1.0]
    return dict(
        name=name or robot.name or p.stem,
        links=tuple(links),
        convention=Convention.MODIFIED,
        base=base,
        tool=tool,
        title=f"{robot.name or p.stem} imported from URDF ({base_link} -> {tip_link})",
        source=str(p),
    )
