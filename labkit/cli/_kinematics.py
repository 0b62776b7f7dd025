"""``labkit robots``, ``labkit fk``, ``labkit ik``: robot files and kinematics at the command line.

Degrees and millimetres exist only here, at the edge (``--deg``, ``--mm``);
the library is called in SI units and radians.
"""

from __future__ import annotations

import argparse
import math
import sys

from labkit.exceptions import LabkitError
from labkit.cli._types import finite_float


def add_commands(sub):
    """Add ``robots``, ``fk`` and ``ik`` to the ``labkit`` subcommands.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommand collection of the ``labkit`` parser.
    """
    sp = sub.add_parser("robots", help="list the bundled robot files")
    sp.set_defaults(func=_cmd_robots)

    units = argparse.ArgumentParser(add_help=False)
    units.add_argument("--deg", action="store_true", help="angles in degrees (default radians)")
    units.add_argument("--mm", action="store_true", help="lengths in millimetres (default metres)")

    sp = sub.add_parser("fk", parents=[units], help="forward kinematics of a robot at joint values q")
    sp.add_argument("robot", help="bundled robot name or robot file")
    sp.add_argument("q", nargs="+", type=finite_float, help="joint values")
    sp.set_defaults(func=_cmd_fk)

    sp = sub.add_parser(
        "ik", parents=[units],
        help="inverse kinematics: all solutions for x y z (3-DOF), x y phi (planar), x y z pitch (4-DOF), "
             "x y z pitch roll (5-DOF), x y z roll pitch yaw (6-DOF)",
    )
    sp.add_argument("robot", help="bundled robot name or robot file")
    sp.add_argument("target", nargs="+", type=finite_float, help="target coordinates")
    sp.set_defaults(func=_cmd_ik)


def _angle_unit(args):
    return "deg" if args.deg else "rad"


def _len_scale(args):
    return 1e3 if args.mm else 1.0


def _fmt_table(header, rows):
    widths = [max(len(str(h)), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    line = "  ".join(str(h).rjust(w) for h, w in zip(header, widths))
    out = [line, "  ".join("-" * w for w in widths)]
    out += ["  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in rows]
    return "\n".join(out)


def _cmd_robots(args):
    from labkit.robot import Robot, bundled_robots

    rows = []
    for name, path in bundled_robots().items():
        try:
            r = Robot.load(path)
            rows.append((name, str(r.n), r.convention.value, r.title))
        except LabkitError as exc:  # a broken file in LABKIT_ROBOT_PATH must not hide the rest
            rows.append((name, "?", "?", f"ERROR: {exc}"))
    print(_fmt_table(("name", "joints", "DH", "description"), rows))
    return 0


def _joint_values(robot, values, deg, mm):
    import numpy as np

    q = np.array(values, dtype=float)
    if q.shape != (robot.n,):
        raise LabkitError(f"{robot.name} has {robot.n} joints; expected {robot.n} joint values, got {q.size}")
    rev = robot.is_revolute
    if deg:
        q[rev] = np.radians(q[rev])
    if mm:
        q[~rev] = q[~rev] / 1e3
    return q


def _print_pose(T, args):
    s = _len_scale(args)
    unit = "mm" if args.mm else "m"

    def clean(v, zero):  # the DH walk's round-off (and -0.0) prints as 0, never as -1.66533e-16 or -0.000000
        return 0.0 if abs(v) <= zero else float(v)

    p = [clean(v, 1e-9 * s) for v in T[:3, 3] * s]  # below a nanometre
    print(f"position [{unit}]:  x = {p[0]:.6g}   y = {p[1]:.6g}   z = {p[2]:.6g}")
    print("transform (rotation | position [" + unit + "]):")
    for i in range(4):
        row = [f"{clean(T[i, j], 1e-12): .6f}" for j in range(3)] + [f"{p[i] if i < 3 else 1.0: .6g}"]
        print("  [" + "  ".join(row) + "]")


def _cmd_fk(args):
    from labkit.robot import Robot
    from labkit.kinematics import fk

    robot = Robot.load(args.robot)
    q = _joint_values(robot, args.q, args.deg, args.mm)
    robot.check_limits(q)
    _print_pose(fk(robot, q), args)
    return 0


def _cmd_ik(args):
    import numpy as np

    from labkit import kinematics
    from labkit.robot import Robot

    robot = Robot.load(args.robot)
    s = _len_scale(args)
    lunit = "mm" if args.mm else "m"
    target = np.array(args.target, dtype=float)
    kind = kinematics.target_kind(robot)
    names = kinematics.target_components(kind)
    if target.size != len(names):
        missing = f": {' '.join(names[target.size:])} missing" if target.size < len(names) else ""
        raise LabkitError(f"{robot.name}: this arm takes {' '.join(names)} ({kind} targets), got {target.size} "
                          f"value{'s' if target.size != 1 else ''}{missing}")
    angle = np.array([nm not in ("x", "y", "z") for nm in names])
    target[~angle] /= s
    if args.deg:
        target[angle] = np.radians(target[angle])
    if kind == "pose":
        from labkit.rotations import matrix_from_rpy

        T = np.eye(4)
        T[:3, :3] = matrix_from_rpy(target[3:])
        T[:3, 3] = target[:3]
        target = T
    sols = kinematics.ik_all(robot, target)
    if not sols.reachable.any():
        distance = float(sols.distance)
        if math.isfinite(distance) and distance > 0.0:
            why = f"target out of reach by {distance * s:.4g} {lunit}"
        else:
            why = f"no configuration takes that orientation (this arm takes {' '.join(names)})"
        print(f"labkit ik: {robot.name}: {why}", file=sys.stderr)
        return 1
    rev = robot.is_revolute
    aunit = "deg" if args.deg else "rad"
    rows = []
    for k, name in enumerate(sols.branches):
        q = np.array(sols.q[k], dtype=float)
        shown = np.where(rev, np.degrees(q) if args.deg else q, q * s)
        if not sols.reachable[k]:
            status = "unreachable"
        else:
            status = "ok" if sols.valid[k] else "outside joint limits"
        rows.append((name, *(f"{v:.4f}" for v in shown), status))
    header = ("branch", *(f"{n} [{aunit if r else lunit}]" for n, r in zip(robot.joint_names, rev)), "status")
    print(f"{robot.name}: solver {sols.solver}, target {' '.join(names)}")
    print(_fmt_table(header, rows))
    return 0
