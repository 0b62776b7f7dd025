"""Inverse kinematics: every closed-form solution with its branch name, or batched numeric IK.

Targets, by :func:`target_kind`: ``"position"`` ``(..., 3)`` [m]; ``"planar"``
``(x, y, phi)`` [m, rad] of planar 3R arms; ``"position_pitch"``,
``"position_pitch_roll"`` and ``"position_yaw"`` ``(x, y, z, angles)`` [m, rad]
of 4- and 5-DOF arms, SCARAs and gantries with a wrist turn, which also take
``(..., 4, 4)`` poses, reached where a branch's FK has the pose's orientation
(the angles are defined in ``docs/ik.md``); ``"pose"`` ``(..., 4, 4)``
``world_from_tool`` transforms for 6-DOF arms.

The closed-form family is chosen from the robot's geometry (joint axes at
``q = 0``, so either DH convention, base and tool transforms included; see
``docs/ik.md``): the first family of the registry that fits (:class:`Solver`
lists them in order). Other robots use :func:`ik_numeric`, which also takes
every kind above.

No NaN ever leaves this module. Where a branch cannot reach a target its
``reachable`` flag is False and its ``q`` holds the finite configuration
obtained by clipping the cosine-law arguments to [-1, 1] (the arm stretched
or folded towards the target): a fill, not a solution.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from labkit.validation import as_batch, as_count, as_number, as_seed
from labkit.exceptions import JointLimitError, OptionError, ShapeError, UnknownBranchError, UnreachableError
from labkit.kinematics._forward import fk
from labkit.kinematics._ik_solvers import (
    FAMILIES, REDUCED, LazyGenerator, build, detect, nearest, solve_closed_form, solve_numeric, task_rows,
    validate_targets, _batch_index, _describe_target, _first_success, _target_words,
)

__all__ = ["Solver", "IKSolutions", "IKResult", "target_kind", "solver_for", "ik", "ik_all", "ik_numeric",
           "pose_from_position_pitch"]

#: IK solver choice: ``AUTO`` picks the closed-form family that fits the robot, else ``NUMERIC``;
#: one member per family of the registry
Solver = Enum("Solver", [("AUTO", "auto"), *((f.name.upper(), f.name) for f in FAMILIES), ("NUMERIC", "numeric")],
              type=str, module=__name__, qualname="Solver")
Solver.__doc__ = "IK solver choice; ``AUTO`` picks the analytic solver that fits the robot, else ``NUMERIC``."


def _as_solver(solver):
    try:
        return Solver(solver if solver is not None else Solver.AUTO)
    except ValueError:
        valid = ", ".join(repr(s.value) for s in Solver)
        raise OptionError(f"unknown IK solver {solver!r}; expected one of {valid}") from None


@dataclass(frozen=True, eq=False)
class IKSolutions:
    """Every closed-form IK solution of a batch of targets.

    Attributes
    ----------
    q : ndarray, shape (..., m, n)
        Joint values [rad, m] of the ``m`` branches. Where ``reachable`` is
        False the row is a finite fill (clipped cosine laws), not a solution.
    reachable : ndarray of bool, shape (..., m)
        The branch reaches the target (joint limits ignored).
    valid : ndarray of bool, shape (..., m)
        Reachable and inside the joint limits.
    branches : tuple of str
        Branch name of each of the ``m`` columns.
    distance : ndarray, shape (...)
        How far the target lies out of reach [m] (0 if any branch reaches
        it). Exact for the 3R solvers; for the 6R solver the wrist centre's
        distance from its reachable shell, measured in the arm plane; for the
        numeric solver the residual of the best attempt [m, rad].
    solver : str
        The solver used (a :class:`Solver` value).

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> sols = ik_all(Robot.load("arduino_arm_3dof"), [0.10, 0.10, -0.10])
    >>> sols.branches[:2]
    ('elbow_up', 'elbow_down')
    >>> np.round(np.degrees(sols["elbow_up"]))
    array([ 45., 114., 109.])
    """

    q: np.ndarray
    reachable: np.ndarray
    valid: np.ndarray
    branches: tuple
    distance: np.ndarray = None
    solver: str = ""

    def __getitem__(self, branch):
        """Joint values of one branch, shape (..., n)."""
        if branch not in self.branches:
            raise UnknownBranchError(f"unknown branch {branch!r}; expected one of {', '.join(self.branches)}")
        return self.q[..., self.branches.index(branch), :]

    def to_dataframe(self, *, degrees=True):
        """One row per branch (single target only): joint values, reachable, valid.

        Parameters
        ----------
        degrees : bool
            Joint values in degrees (columns ``"q1 [deg]"`` ...) instead of the
            raw values [rad, m] (columns ``"q1"`` ...). Degrees convert every
            column, prismatic ones included.

        Returns
        -------
        pandas.DataFrame
            Indexed by ``branch``; one column per joint, then ``reachable`` and
            ``valid``.

        Raises
        ------
        ShapeError
            The solutions hold more than one target (``q`` is not (m, n)).
        """
        if self.q.ndim != 2:
            raise ShapeError(f"to_dataframe needs one target (q of shape (m, n)), got {self.q.shape}")
        return _joint_table(self.q, degrees, self.branches, reachable=self.reachable, valid=self.valid)


@dataclass(frozen=True, eq=False)
class IKResult:
    """Result of :func:`ik_numeric`.

    Attributes
    ----------
    q : ndarray, shape (..., n)
        Joint values [rad, m]; for failed targets the best configuration found.
    success : ndarray of bool, shape (...)
        Residual below tolerance.
    iterations : ndarray of int, shape (...)
        LM iterations used (all restarts together).
    residual : ndarray, shape (...)
        Final task error [m, rad]: norm of position error and ``2 sin(angle/2)``
        of the orientation error.
    """

    q: np.ndarray
    success: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray

    def to_dataframe(self):
        """Flat table: one row per target.

        Returns
        -------
        pandas.DataFrame
            Columns ``q1 .. qn`` [rad, m], ``success``, ``iterations`` and
            ``residual`` [m, rad]; batch dimensions flattened in C order.
        """
        return _joint_table(self.q.reshape(-1, self.q.shape[-1]), success=self.success.reshape(-1),
                            iterations=self.iterations.reshape(-1), residual=self.residual.reshape(-1))


def _joint_table(q, degrees=False, branches=None, **columns):
    """A table of joint values ``q`` (N, n) (``q1 [deg]`` ... in degrees, else ``q1`` ...), then ``columns``."""
    import pandas as pd

    unit, q = (" [deg]", np.degrees(q)) if degrees else ("", q)
    return pd.DataFrame({**{f"q{j + 1}{unit}": q[:, j] for j in range(q.shape[1])}, **columns},
                        index=None if branches is None else pd.Index(branches, name="branch"))


def target_kind(robot):
    """What an IK target of ``robot`` is: ``"position"``, ``"planar"``, ``"position_pitch[_roll]"``, ``"position_yaw"``, ``"pose"``.

    Parameters
    ----------
    robot : Robot

    Returns
    -------
    str
        ``"planar"`` for planar 3R arms (target ``(x, y, phi)``),
        ``"position_pitch"`` for 4-DOF yaw-pitch-pitch-pitch arms (``(x, y, z,
        pitch)``), ``"position_pitch_roll"`` for 5-DOF yaw-pitch-pitch-pitch-roll
        arms (``(x, y, z, pitch, roll)``), ``"position_yaw"`` for SCARA arms
        (``(x, y, z, yaw)``), ``"pose"`` for robots with 6 or more
        joints (target ``(4, 4)``), otherwise ``"position"`` (target ``(x, y, z)``).

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> [target_kind(Robot.load(n)) for n in ("arduino_arm_3dof", "planar3r_seed004", "puma560")]
    ['position', 'planar', 'pose']
    """
    found, _ = detect(robot)
    if found is not None:
        return found.kind
    return "pose" if robot.n >= 6 else "position"


def solver_for(robot):
    """The :class:`Solver` that ``solver="auto"`` uses for ``robot``.

    Parameters
    ----------
    robot : Robot

    Returns
    -------
    Solver
        The analytic solver whose structure ``robot`` matches, else
        ``Solver.NUMERIC``.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> solver_for(Robot.load("puma600_seed002")).value
    'spherical_wrist'
    """
    found, _ = detect(robot)
    return Solver(found.name) if found is not None else Solver.NUMERIC


def _family(robot, solver):
    """The closed-form family ``solver`` asks for on ``robot``, or None for the numeric solver."""
    solver = _as_solver(solver)
    if solver is Solver.NUMERIC:
        return None
    found, _ = detect(robot)
    if solver is Solver.AUTO or (found is not None and found.name == solver.value):
        return found
    impl, why = build(robot, solver.value)
    if impl is None:
        fits = found.name if found is not None else "numeric"
        raise OptionError(
            f"{robot.name}: solver {solver.value!r} does not fit this robot ({why}); "
            f"the automatic choice is {fits!r}"
        )
    if impl.kind != target_kind(robot):
        raise OptionError(f"{robot.name}: solver {solver.value!r} expects {impl.kind} targets")
    return impl


def _solutions(robot, family, kind, flat, q0=None):
    """``(q (N, m, n), reachable (N, m), valid (N, m), distance (N,), branches)`` of validated targets.

    The numeric solver is a family of one branch, ``"numeric"``: reachable where
    it converged, ``distance`` its residual elsewhere [m, rad].
    """
    if family is not None:
        if kind in REDUCED and flat.ndim == 3:
            return _pose_solutions(robot, family, flat)
        return (*solve_closed_form(robot, family, flat), tuple(family.branches))
    q, ok, _, res = _numeric(robot, kind, flat, q0, None, tol=None, max_iter=50, restarts=10, seed=0)
    q = q[:, None, :]
    return q, ok[:, None], ok[:, None] & robot.within_limits(q), np.where(ok, 0.0, res), ("numeric",)


def _pose_solutions(robot, family, T):
    """Poses as targets of a 4- or 5-DOF family: solved on the targets they reach, kept where FK has the
    pose's orientation (to 1e-6, the tolerance of a rigid transform; the point itself is reached exactly)."""
    q, reach, valid, distance = solve_closed_form(robot, family, family.target_of(T))
    same = np.abs(fk(robot, q)[..., :3, :3] - T[:, None, :3, :3]).max(axis=(-2, -1)) < 1e-6
    return q, reach & same, valid & same, distance, tuple(family.branches)


def ik_all(robot, target, *, solver="auto"):
    """Every IK solution of each target, with branch names, reachability and limit checks.

    Parameters
    ----------
    robot : Robot
    target : array_like
        ``(..., 3)`` positions [m], ``(..., 3)`` planar ``(x, y, phi)`` [m, rad]
        or ``(..., 4, 4)`` poses, as :func:`target_kind` says.
    solver : Solver or str
        ``"auto"`` (default), a specific analytic solver, or ``"numeric"``
        (one branch, named ``"numeric"``, from :func:`ik_numeric`).

    Returns
    -------
    IKSolutions
        ``q`` of shape ``(..., m, n)``; for one target ``(m, n)``. Nothing is
        raised for unreachable targets: see ``reachable``, ``valid`` and
        ``distance``.

    Raises
    ------
    ShapeError
        Wrong shape, non-finite values or a pose that is not a rigid transform.
    ValueError
        Unknown solver, or a forced solver that does not fit the robot.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> puma = Robot.load("puma600_seed002")
    >>> T = puma.fk(np.full(6, np.pi / 6))
    >>> sols = ik_all(puma, T)
    >>> sols.q.shape, int(sols.valid.sum())
    ((8, 6), 8)
    >>> bool(np.any(np.all(np.abs(sols.q - np.pi / 6) < 1e-9, axis=1)))
    True
    """
    kind = target_kind(robot)
    family = _family(robot, solver)
    n = robot.n
    flat, lead = validate_targets(target, kind)
    q, reach, valid, distance, branches = _solutions(robot, family, kind, flat)
    m = len(branches)
    return IKSolutions(
        q.reshape(lead + (m, n)), reach.reshape(lead + (m,)), valid.reshape(lead + (m,)),
        branches, distance.reshape(lead), Solver.NUMERIC.value if family is None else family.name,
    )


def _per_target(q, n, lead, name):
    """Joint values [rad, m] given once or per target, validated, as one row (N, n) per target."""
    return np.broadcast_to(as_batch(q, (n,), name), lead + (n,)).reshape(-1, n)


def _branch_index(branches, aliases, branch):
    name = aliases.get(branch, branch) if isinstance(branch, str) else branch
    if name not in branches:
        extra = f" (aliases: {', '.join(sorted(aliases))})" if aliases else ""
        raise OptionError(f"unknown branch {branch!r}; expected one of {', '.join(branches)}{extra}")
    return branches.index(name)


def ik(robot, target, *, branch=None, q_near=None, solver="auto"):
    """One IK solution per target.

    Parameters
    ----------
    robot : Robot
    target : array_like
        As :func:`ik_all`: ``(..., 3)`` or ``(..., 4, 4)``.
    branch : str, optional
        Branch name (``IKSolutions.branches`` or a documented alias such as
        ``"elbow_minus"`` or roboticstoolbox's ``"lun"``). Default: the valid
        solution nearest ``q_near``, or the first valid branch.
    q_near : array_like, shape (n,) or (..., n), optional
        Preferred configuration [rad, m] (e.g. the current one); revolute
        differences are wrapped to (-pi, pi].
    solver : Solver or str
        As :func:`ik_all`. With ``"numeric"`` ``q_near`` is the initial guess.

    Returns
    -------
    q : ndarray, shape (..., n)
        Joint values [rad, m] inside the joint limits.

    Raises
    ------
    UnreachableError
        A target lies outside the workspace; ``.distance`` says by how much [m]
        and ``.index`` which target (``None`` for a single target).
    JointLimitError
        A target is reachable only outside the joint limits; names the joint.
    ShapeError
        Bad shape or non-finite values.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> arm = Robot.load("planar3r_seed004")
    >>> q = ik(arm, [0.3, 0.2, np.pi / 4], branch="elbow_minus")
    >>> bool(q[1] < 0), np.allclose(arm.fk(q)[:2, 3], [0.3, 0.2])
    (True, True)
    """
    kind = target_kind(robot)
    family = _family(robot, solver)
    n = robot.n
    branches, aliases = (("numeric",), {}) if family is None else (family.branches, family.aliases)
    idx = None if branch is None else _branch_index(branches, aliases, branch)
    flat, lead = validate_targets(target, kind)
    qn = None if q_near is None else _per_target(q_near, n, lead, "q_near")
    q, reach, valid, dist, branches = _solutions(robot, family, kind, flat, qn)
    valid_t = valid[:, idx] if idx is not None else valid.any(axis=1)
    if valid_t.all():  # (valid implies reachable: the usual case needs no more checks)
        out = q[:, idx] if idx is not None else q[np.arange(q.shape[0]), nearest(robot, q, valid, qn)]
        return out.reshape(lead + (n,))
    reach_t = reach[:, idx] if idx is not None else reach.any(axis=1)
    i = int(np.flatnonzero(~(valid_t if reach_t.all() else reach_t))[0])
    target, where = _describe_target(kind, flat[i]), "" if not lead else f" (target {_batch_index(i, lead)})"
    if not reach_t.all():
        distance = dist[i]
        if family is None:
            why = (f"numeric IK found no solution inside the joint limits for {target}{where}; the closest "
                   f"configuration found misses it by {dist[i]:.4g} (m and rad combined)")
        elif idx is not None and reach[i].any():
            distance, why = 0.0, (f"branch {branches[idx]!r} cannot reach {target}{where}; reachable branches: "
                                  f"{', '.join(b for b, r in zip(branches, reach[i]) if r)}")
        elif not (np.isfinite(dist[i]) and dist[i] > 0.0):  # the point is in reach: the orientation is not
            distance, why = 0.0, (f"no configuration takes the orientation of target {target}{where}; this arm "
                                  f"takes {_target_words(kind)}")
        else:
            why = f"target {target}{where} is out of reach by {dist[i]:.4g} m ({dist[i] * 1e3:.1f} mm)"
        raise UnreachableError(f"{robot.name}: {why}", distance=distance, index=_batch_index(i, lead))
    cols = [idx] if idx is not None else [k for k in range(len(branches)) if reach[i, k]]
    reasons, joint = [], None
    for k in cols:
        try:
            robot.check_limits(q[i, k])
        except JointLimitError as exc:
            joint = exc.joint if joint is None else joint
            reasons.append(f"{branches[k]}: {str(exc).split(': ', 1)[-1]}")
    raise JointLimitError(f"{robot.name}: target {target}{where} is reachable only outside the joint limits: "
                          + "; ".join(reasons), joint=joint, index=_batch_index(i, lead))


def _numeric(robot, kind, flat, q0, mask, *, tol, max_iter, restarts, seed):
    sides = 1
    if kind in REDUCED:  # x y z pitch [roll] / yaw: every tool pose that reaches them (front, back), as poses
        if flat.ndim == 2:
            flat = _reduced_family(robot, kind).poses(flat)
            sides = flat.shape[1]
            flat = flat.reshape(-1, 4, 4)
            q0 = None if q0 is None else np.repeat(q0, sides, axis=0)
        kind = "pose"
    rows = task_rows(kind)
    if mask is not None:
        mask = as_batch(mask, (), "mask", bools=True).astype(bool).reshape(-1)
        if mask.shape != (len(rows),):
            raise ShapeError(f"expected mask with {len(rows)} entries for {kind} targets, got {mask.shape}")
        rows = tuple(r for r, keep in zip(rows, mask) if keep)
        if not rows:
            raise OptionError("mask selects no task coordinate")
    rng = LazyGenerator(seed)
    q, ok, it, res = solve_numeric(robot, kind, flat, q0, rows, tol=tol, max_iter=max_iter, restarts=restarts, rng=rng)
    if sides == 1:
        return q, ok, it, res
    q, ok, _, res = _first_success(sides, q, ok, it, res)  # the first pose reached (iterations: all poses')
    return q, ok, it.reshape(-1, sides).sum(axis=1), res


def _reduced_family(robot, kind):
    """The closed-form family that defines ``kind``'s angles (pitch, roll, yaw) on ``robot``."""
    found, _ = detect(robot)
    if found is None or found.kind != kind:
        raise OptionError(f"{robot.name}: {_target_words(kind)} targets are defined by the closed form of arms "
                          f"that take them; this arm takes {_target_words(target_kind(robot))} (or use "
                          f"kind='pose')")
    return found


def ik_numeric(robot, target, q0=None, *, kind=None, mask=None, tol=None, max_iter=50, restarts=10, seed=0):
    """Batched damped-least-squares (Levenberg-Marquardt) IK for any robot.

    All targets iterate together on arrays (one batched FK + Jacobian per
    iteration). Steps are projected onto the joint limits; targets that have
    not converged after ``max_iter`` iterations restart from a random
    configuration inside the limits, up to ``restarts`` times.

    Parameters
    ----------
    robot : Robot
    target : array_like
        ``(..., 3)`` or ``(..., 4, 4)`` as :func:`target_kind` (or ``kind``) says.
    q0 : array_like, shape (n,) or (..., n), optional
        Initial guess [rad, m]; default random inside the limits (seeded).
    kind : {"position", "planar", "pose", "position_pitch", "position_pitch_roll", "position_yaw"}, optional
        Override :func:`target_kind` (e.g. ``"position"`` for a 6R arm). The
        kinds with angles of 4- and 5-DOF arms and SCARAs take the same
        targets as their closed form (:func:`ik`), solved on the tool poses
        that form defines (:func:`pose_from_position_pitch`), so a branch can be
        cross-checked numerically with the same target.
    mask : array_like of bool, optional
        Which task coordinates to match: 3 entries for position/planar
        targets, 6 (``x, y, z, rx, ry, rz``) for poses and the kinds with
        angles - e.g. for an under-actuated arm, ``[1, 1, 1, 0, 0, 1]``.
    tol : float, optional
        Success threshold on the residual [m, rad]. Default: 1e-10 times the
        arm's reach (:attr:`Robot.reach`, at least 1 mm), the same relative precision for a 5 cm and a
        7 m arm.
    max_iter, restarts : int
        Iterations per attempt and number of random restarts.
    seed : int >= 0, numpy.random.Generator or None
        Seed of the random initial guesses (None: fresh entropy).

    Returns
    -------
    IKResult
        ``q (..., n)``, ``success (...)``, ``iterations (...)``, ``residual (...)``.
        Nothing is raised for failed targets; their ``q`` is the best
        configuration found (finite).

    Raises
    ------
    ShapeError
        Wrong shape, not numbers, NaN/inf or entries beyond 1e9 (m, rad), or a
        pose that is not a rigid transform.
    OptionError
        An unknown kind, or a kind with angles that the arm's closed form does not take.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> puma = Robot.load("puma560")
    >>> T = puma.fk([0.1, 0.5, -0.3, 0.2, 0.4, 0.1])
    >>> res = ik_numeric(puma, T)
    >>> bool(res.success), bool(res.residual < 1e-9)
    (True, True)
    """
    if kind is None:
        kind = target_kind(robot)
    else:
        task_rows(kind)  # an unknown kind raises OptionError
    flat, lead = validate_targets(target, kind)
    n = robot.n
    if q0 is not None:
        q0 = _per_target(q0, n, lead, "q0")
    tol = None if tol is None else as_number(tol, "tol", positive=True)
    q, ok, it, res = _numeric(robot, kind, flat, q0, mask, tol=tol, seed=as_seed(seed),
                              max_iter=as_count(max_iter, "max_iter", minimum=1), restarts=as_count(restarts, "restarts"))
    return IKResult(q.reshape(lead + (n,)), ok.reshape(lead), it.reshape(lead), res.reshape(lead))


def pose_from_position_pitch(robot, target):
    """Tool poses of ``(x, y, z, pitch)`` targets of a 4-DOF arm (``(x, y, z, pitch, roll)`` of a 5-DOF arm).

    The pose the arm takes facing the target (its IK also takes the target itself).

    Parameters
    ----------
    robot : Robot
        An arm whose closed-form family is ``yaw_pitch_pitch_pitch`` or ``yaw_pitch_pitch_pitch_roll``.
    target : array_like, shape (..., 4) or (..., 5)
        Tool point ``(x, y, z)`` [m], pitch [rad]: the elevation of the approach
        direction above the plane perpendicular to axis 1 (positive towards
        +axis 1; 0 = pointing away from axis 1 in the arm's plane), and for a
        5-DOF arm the roll [rad] about the approach direction.

    Returns
    -------
    T : ndarray, shape (..., 4, 4)
        ``world_from_tool`` poses [m].

    Raises
    ------
    OptionError
        The robot is not of those families.
    ShapeError
        Bad target shape or values.

    Examples
    --------
    >>> from labkit.robot import Robot
    >>> T = pose_from_position_pitch(Robot.load("openmanipulator_x"), [0.2, 0.0, 0.1, -np.pi / 2])
    >>> np.round(T[:3, 0], 6).tolist()  # the approach (tool x) points straight down
    [0.0, 0.0, -1.0]
    """
    found, reasons = detect(robot)
    if found is None or found.kind not in REDUCED:
        raise OptionError(
            f"{robot.name}: (x, y, z, pitch[, roll]) targets need a 4-DOF yaw-pitch-pitch-pitch or 5-DOF "
            f"yaw-pitch-pitch-pitch-roll arm ({reasons.get('yaw_pitch_pitch_pitch', 'its solver is ' + repr(getattr(found, 'name', None)))})"
        )
    t, lead = validate_targets(target, found.kind)
    if t.ndim == 3:
        raise ShapeError(f"expected {_target_words(found.kind)} targets, got poses")
    return found.pose(t).reshape(lead + (4, 4))
