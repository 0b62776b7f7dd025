"""Acceptance run of the closed-form IK families added in issue 14, with throughput beside numeric IK.

Run::

    python benchmarks/bench_ik_families.py            # 10,000 random in-limit targets per family
    python benchmarks/bench_ik_families.py --quick    # 500 targets

For each family (planar 2R with a tilted plane, a 4-DOF yaw-pitch-pitch-pitch arm, IRB140 and KR5
with their shoulder offset, UR5; issue 25: OpenMANIPULATOR-X, SO-101, AL5D with (x, y, z, pitch[, roll])
targets)
it draws random configurations inside the joint limits, takes their FK as targets and prints:

* solved: the share of targets whose starting configuration is among the valid branches
  (1e-7 rad) and whose every reachable branch reaches the target (1e-9);
* complete: for a subset of targets, numeric IK (``ik_numeric``) from many random starts
  found no solution that is not a valid branch (share of numeric solutions within 1e-6 rad of one,
  or within 10 x residual / smallest singular value next to a singularity; a 4- or 5-DOF
  arm's numeric IK runs on the tool poses, the closed forms on their (x, y, z, pitch[, roll]));
* targets/s of ``ik_all`` (all branches) and of ``ik_numeric`` (one solution), same run,
  process CPU time, one thread, and their ratio.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from labkit.kinematics import fk, ik_all, ik_numeric, jacobian, target_from_pose, target_kind  # noqa: E402
from labkit.kinematics import REDUCED_KINDS as REDUCED  # noqa: E402
from labkit.robot import Link, Robot  # noqa: E402
from labkit.rotations import matrix_from_rpy, wrap_angle  # noqa: E402


def planar_2r():
    base = np.eye(4)
    base[:3, :3] = matrix_from_rpy([0.4, 1.0, -0.2])
    base[:3, 3] = [0.1, 0.2, 0.3]
    links = (Link(a=0.3, d=0.05, limits=(-2.5, 2.5)), Link(a=0.2, d=0.1, theta=0.3, alpha=np.pi, limits=(-2.8, 2.8)))
    return Robot("planar_2r_tilted", links, base=base)


def arm4():
    """MeArm / Dobot-like 4-DOF arm (base yaw and three pitch joints)."""
    links = (Link(d=0.1, alpha=np.pi / 2, limits=(-np.pi, np.pi), name="yaw"),
             Link(a=0.15, theta=np.pi / 2, limits=(-np.pi, np.pi), name="shoulder"),
             Link(a=0.15, limits=(-2.8, 2.8), name="elbow"),
             Link(a=0.05, limits=(-2.8, 2.8), name="wrist"))
    return Robot("arm4_mearm_like", links)


def target_of(robot, q):
    return target_from_pose(robot, fk(robot, q))


def difference(robot, reached, target):
    d = reached - target
    if target_kind(robot) in REDUCED:
        d[..., 3:] = wrap_angle(d[..., 3:])
    return d


def timed(func):
    t0 = time.process_time()
    out = func()
    return out, time.process_time() - t0


def run(robot, n_targets, n_complete, n_starts, rng):
    lim = robot.joint_limits
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(n_targets, robot.n))
    target = target_of(robot, q)
    sols, t_all = timed(lambda: ik_all(robot, target))
    reached = target_of(robot, sols.q)
    err = np.abs(difference(robot, reached, target[:, None])).reshape(n_targets, len(sols.branches), -1).max(axis=-1)
    hits = np.where(sols.reachable, err, 0.0).max(axis=1) < 1e-9
    start = np.where(sols.valid, np.abs(wrap_angle(sols.q - q[:, None])).max(axis=-1), np.inf).min(axis=1)
    solved = hits & (start < 1e-7)
    # completeness against numeric IK from many random starts
    reduced = target_kind(robot) in REDUCED
    sub = fk(robot, q[:n_complete]) if reduced else target[:n_complete]
    rep = np.repeat(sub, n_starts, axis=0)
    starts = rng.uniform(lim[:, 0], lim[:, 1], size=(len(rep), robot.n))
    kind = "pose" if reduced else None
    res, t_num = timed(lambda: ik_numeric(robot, rep, q0=starts, kind=kind, restarts=3, max_iter=100))
    qa = np.repeat(sols.q[:n_complete], n_starts, axis=0)
    valid = np.repeat(sols.valid[:n_complete], n_starts, axis=0)
    gap = np.where(valid, np.abs(wrap_angle(qa - res.q[:, None])).max(axis=-1), np.inf).min(axis=-1)
    # a numeric solution is only as exact as its residual over the smallest singular value: next to a
    # singularity (an arm stretched out) 1e-10 of residual leaves ~1e-6 rad of play
    sigma = np.linalg.svd(jacobian(robot, res.q), compute_uv=False)[:, min(robot.n, 6) - 1]
    tol = np.maximum(1e-6, 10.0 * res.residual / np.maximum(sigma, 1e-12))
    matched = (gap < tol)[res.success]
    print(
        f"{robot.name:18s} {sols.solver:21s} {len(sols.branches)} branches  solved {100 * solved.mean():6.2f}% "
        f"of {n_targets:,}  complete: {matched.sum():,}/{res.success.sum():,} numeric solutions matched "
        f"({100 * matched.mean():.2f}%)  closed form {n_targets / t_all:12,.0f} targets/s  "
        f"numeric {len(rep) / t_num:9,.0f} targets/s  ratio {n_targets / t_all / (len(rep) / t_num):8,.0f}x"
    )
    return solved.all() and matched.all()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="500 targets instead of 10,000")
    args = parser.parse_args()
    n = 500 if args.quick else 10_000
    rng = np.random.default_rng(14)
    ok = True
    for robot in (planar_2r(), arm4(), Robot.load("irb140"), Robot.load("kr5"), Robot.load("ur5"),
                  Robot.load("openmanipulator_x"), Robot.load("so101"), Robot.load("al5d")):
        ok &= run(robot, n, n_complete=20 if args.quick else 200, n_starts=20, rng=rng)
    print("all families: 100 % solved, complete" if ok else "FAILED: see the rows above")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
