"""Dynamics speed of labkit (plain numpy) against compiled peers measured in the same run.

Run::

    python benchmarks/bench_dynamics.py            # 100k PUMA 560 states
    python benchmarks/bench_dynamics.py --quick    # 10k states, fewer repeats

Rows: inverse dynamics (recursive Newton-Euler) and the mass matrix of the PUMA 560 (Armstrong/
Corke inertias, motors and friction as in roboticstoolbox's model) for a batch of random states
and for single calls. Peers, each when importable (``pip install -e '.[bench,crosscheck]'``):
pinocchio ``rnea``/``crba`` called in a Python loop (one state per call; built here from
labkit's frames at q = 0 with the same inertias, no motors: its M gets the armature added as
pinocchio's ``model.armature``), and roboticstoolbox's C ``rne`` given the whole batch in one
call (its ``inertia`` is n ``rne`` calls per state from Python: timed on a slice and scaled).
Results are compared before timing (largest relative difference printed). Times are process
CPU time, best of several repeats; threads pinned to one. Figures are printed, never asserted.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from labkit.dynamics import inverse_dynamics, mass_matrix  # noqa: E402
from labkit.kinematics import fk_frames  # noqa: E402
from labkit.robot import Convention, Robot  # noqa: E402


def seconds(func, repeat=3):
    """Best-of-``repeat`` process CPU time of one ``func()`` call [s] (after a warm-up call)."""
    func()
    best = float("inf")
    for _ in range(repeat):
        t0 = time.process_time()
        func()
        best = min(best, time.process_time() - t0)
    return max(best, 1e-9)


def pinocchio_model(robot):
    """pinocchio model of a revolute standard-DH robot with labkit's inertias and armature, or None."""
    try:
        import pinocchio as pin
    except ImportError:
        return None
    assert robot.convention is Convention.STANDARD and robot.is_revolute.all() and not robot.flip.any()
    T = fk_frames(robot, np.zeros(robot.n))
    model = pin.Model()
    parent, frame = 0, np.eye(4)
    for i, lk in enumerate(robot.links):
        placement = np.linalg.inv(frame) @ T[i]  # joint i turns about z of frame i - 1
        jid = model.addJoint(parent, pin.JointModelRZ(), pin.SE3(placement[:3, :3], placement[:3, 3]), f"q{i + 1}")
        link = np.linalg.inv(T[i]) @ T[i + 1]  # frame i in the joint frame at q = 0
        R = link[:3, :3]
        com = link[:3, 3] + R @ np.array(lk.inertial.com)
        model.appendBodyToJoint(jid, pin.Inertia(lk.inertial.mass, com, R @ lk.inertial.matrix @ R.T), pin.SE3.Identity())
        parent, frame = jid, T[i]
    model.armature = np.array([lk.motor.gear_ratio ** 2 * lk.motor.inertia for lk in robot.links])
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    return model


def rtb_model():
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import roboticstoolbox as rtb
    except ImportError:
        return None
    return rtb.models.DH.Puma560().nofriction(True, True)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="10k states instead of 100k")
    args = parser.parse_args(argv)
    N = 10_000 if args.quick else 100_000
    puma = Robot.load("puma560")
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-2, 2, (N, 6)) for _ in range(3))
    pm, rm = pinocchio_model(puma), rtb_model()
    tau = inverse_dynamics(puma, q, qd, qdd, friction=False)
    M = mass_matrix(puma, q)
    rows = []  # (what, labkit [s per state], peer name, peer [s per state])

    t_id = seconds(lambda: inverse_dynamics(puma, q, qd, qdd, friction=False)) / N
    t_m = seconds(lambda: mass_matrix(puma, q)) / N
    print(f"PUMA 560, {N} random states, one core (process CPU time, best of 3)\n")
    if pm is not None:
        import pinocchio as pin

        data = pm.createData()
        k = min(N, 20_000)
        err = max(np.abs(pin.rnea(pm, data, q[i], qd[i], qdd[i]) - tau[i]).max() / np.abs(tau[i]).max()
                  for i in range(100))
        print(f"pinocchio rnea vs labkit: largest relative difference {err:.1e} (100 states)")
        Mp = pin.crba(pm, data, q[0])
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        print(f"pinocchio crba vs labkit: {np.abs(Mp - M[0]).max() / np.abs(M[0]).max():.1e}")

        def rnea_loop():
            for i in range(k):
                pin.rnea(pm, data, q[i], qd[i], qdd[i])

        def crba_loop():
            for i in range(k):
                pin.crba(pm, data, q[i])

        rows += [("inverse dynamics, batch", t_id, "pinocchio rnea, Python loop", seconds(rnea_loop) / k),
                 ("mass matrix, batch", t_m, "pinocchio crba, Python loop", seconds(crba_loop) / k)]
    if rm is not None:
        g = np.array([0.0, 0.0, -9.81])
        err = np.abs(rm.rne(q[:100], qd[:100], qdd[:100], gravity=g) - tau[:100]).max() / np.abs(tau[:100]).max()
        print(f"roboticstoolbox rne (C) vs labkit: largest relative difference {err:.1e} (100 states)")
        k = min(N, 1000)
        rows += [("inverse dynamics, batch", t_id, "rtb rne (C, whole batch)",
                  seconds(lambda: rm.rne(q, qd, qdd, gravity=g)) / N),
                 ("mass matrix, batch", t_m, "rtb inertia (n C rne per state)", seconds(lambda: rm.inertia(q[:k])) / k)]
    one = (q[:1][0], qd[0], qdd[0])
    t1_id = seconds(lambda: inverse_dynamics(puma, *one, friction=False), repeat=20)
    t1_m = seconds(lambda: mass_matrix(puma, one[0]), repeat=20)
    if pm is not None:
        rows += [("inverse dynamics, one state", t1_id, "pinocchio rnea", seconds(lambda: pin.rnea(pm, data, *one), 20)),
                 ("mass matrix, one state", t1_m, "pinocchio crba", seconds(lambda: pin.crba(pm, data, one[0]), 20))]
    if rm is not None:
        rows += [("inverse dynamics, one state", t1_id, "rtb rne (C)", seconds(lambda: rm.rne(*one, gravity=g), 20)),
                 ("mass matrix, one state", t1_m, "rtb inertia", seconds(lambda: rm.inertia(one[0]), 20))]
    if not rows:
        rows = [("inverse dynamics, batch", t_id, "n/a", float("nan")), ("mass matrix, batch", t_m, "n/a", float("nan"))]
    print(f"\n{'what':30s} {'labkit [us/state]':>18s}   {'peer':34s} {'peer [us/state]':>16s} {'labkit/peer':>12s}")
    for what, ours, peer, theirs in rows:
        print(f"{what:30s} {ours * 1e6:18.2f}   {peer:34s} {theirs * 1e6:16.2f} {ours / theirs:12.2f}")


if __name__ == "__main__":
    main()
