"""Throughput of labkit's kinematics on one core, against roboticstoolbox-python and pinocchio.

Run::

    python benchmarks/bench_kinematics.py            # full run (~1 min)
    python benchmarks/bench_kinematics.py --quick    # smaller batches

Prints, for the PUMA 560: batched FK, batched geometric Jacobian, analytic IK
(all 8 solutions per target) and numeric IK, each with the same measured in
the same run for roboticstoolbox-python (``fkine`` on a trajectory, ``jacob0``,
``ikine_a``, ``ikine_LM``) and pinocchio (FK and frame Jacobian; it has no IK),
when importable, and the ratios. Targets of issue 2 are printed, not asserted.
Threads are pinned to one (``OMP_NUM_THREADS=1`` etc., set before numpy loads).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from labkit.kinematics import fk, ik_all, ik_numeric, jacobian  # noqa: E402
from labkit.robot import Convention, Robot  # noqa: E402

TARGETS = {"FK": 3e6, "Jacobian": 1e6, "analytic IK": 2e5, "numeric IK": 4e3}


def rate(func, count, repeat=3):
    """Best-of-``repeat`` throughput [items/s] of ``func()`` which processes ``count`` items.

    Uses process CPU time, so other jobs on a shared machine do not distort
    the ratios (with one thread it equals wall time on an idle core).
    """
    best = float("inf")
    for _ in range(repeat):
        t0 = time.process_time()
        func()
        best = min(best, time.process_time() - t0)
    return count / best


def rtb_model():
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import roboticstoolbox as rtb
    except ImportError:
        return None
    return rtb.models.DH.Puma560()


def pinocchio_model(robot):
    """A pinocchio model of a DH robot (joint placements from the DH rows) or None."""
    try:
        import pinocchio as pin
    except ImportError:
        return None

    def rz(t):
        T = np.eye(4)
        T[:2, :2] = [[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]]
        return T

    def rx(t):
        T = np.eye(4)
        T[1:3, 1:3] = [[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]]
        return T

    def tr(x=0.0, z=0.0):
        T = np.eye(4)
        T[0, 3], T[2, 3] = x, z
        return T

    model = pin.Model()
    parent = 0
    post = robot.base
    for i, lk in enumerate(robot.links):
        if robot.convention is Convention.STANDARD:
            pre = rz(lk.theta) if lk.is_revolute else rz(lk.theta) @ tr(z=lk.d)
            after = (tr(z=lk.d) if lk.is_revolute else np.eye(4)) @ tr(x=lk.a) @ rx(lk.alpha)
        else:
            pre = rx(lk.alpha) @ tr(x=lk.a) @ rz(lk.theta) @ (np.eye(4) if lk.is_revolute else tr(z=lk.d))
            after = tr(z=lk.d) if lk.is_revolute else np.eye(4)
        M = post @ pre
        joint = pin.JointModelRZ() if lk.is_revolute else pin.JointModelPZ()
        parent = model.addJoint(parent, joint, pin.SE3(M[:3, :3], M[:3, 3]), f"j{i + 1}")
        post = after
    T = post @ robot.tool
    fid = model.addFrame(pin.Frame("tool", parent, 0, pin.SE3(T[:3, :3], T[:3, 3]), pin.FrameType.OP_FRAME))
    return pin, model, model.createData(), fid


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller batches")
    args = ap.parse_args(argv)
    scale = 0.2 if args.quick else 1.0

    puma = Robot.load("puma560")
    rng = np.random.default_rng(2026)  # not the numeric solver's seed 0
    lim = puma.joint_limits
    N = int(200_000 * scale)
    q = rng.uniform(lim[:, 0], lim[:, 1], size=(N, 6))
    T = fk(puma, q)
    results = {}

    # -- labkit ------------------------------------------------------------------
    results["FK"] = {"labkit": rate(lambda: fk(puma, q), N)}
    results["Jacobian"] = {"labkit": rate(lambda: jacobian(puma, q), N)}
    nik = int(100_000 * scale)
    results["analytic IK"] = {"labkit": rate(lambda: ik_all(puma, T[:nik]), nik)}
    nnum = int(10_000 * scale)
    res = ik_numeric(puma, T[:nnum])
    results["numeric IK"] = {"labkit": rate(lambda: ik_numeric(puma, T[:nnum]), nnum, repeat=2)}
    numeric_note = f"success {res.success.mean():.2%}, max residual {res.residual.max():.1e}"

    # -- roboticstoolbox-python ----------------------------------------------------------
    ref = rtb_model()
    if ref is not None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            n = int(5_000 * scale)
            results["FK"]["rtb"] = rate(lambda: ref.fkine(q[:n]), n)
            n = int(2_000 * scale)
            results["Jacobian"]["rtb"] = rate(lambda: [ref.jacob0(qk) for qk in q[:n]], n)
            n = int(500 * scale)
            configs = ("lun", "luf", "ldn", "ldf", "run", "ruf", "rdn", "rdf")
            results["analytic IK"]["rtb"] = rate(lambda: [ref.ikine_a(T[:n], config=c) for c in configs], n, 1)
            n = int(200 * scale)
            results["numeric IK"]["rtb"] = rate(lambda: [ref.ikine_LM(Tk) for Tk in T[:n]], n, 1)

    # -- pinocchio ---------------------------------------------------------------------
    pm = pinocchio_model(puma)
    pin_note = "not installed"
    if pm is not None:
        pin, model, data, fid = pm
        qk = q[:5]
        err = 0.0
        for k in range(len(qk)):
            pin.framesForwardKinematics(model, data, qk[k])
            err = max(err, np.abs(data.oMf[fid].homogeneous - T[k]).max())
            J = pin.computeFrameJacobian(model, data, qk[k], fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            err = max(err, np.abs(J - jacobian(puma, qk[k])).max())
        pin_note = f"pinocchio {pin.__version__}, max |difference| to labkit {err:.1e}"
        n = int(20_000 * scale)

        def pin_fk():
            for qq in q[:n]:
                pin.framesForwardKinematics(model, data, qq)
                data.oMf[fid].homogeneous

        def pin_jac():
            for qq in q[:n]:
                pin.computeFrameJacobian(model, data, qq, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)

        results["FK"]["pinocchio"] = rate(pin_fk, n)
        results["Jacobian"]["pinocchio"] = rate(pin_jac, n)

    # -- report -------------------------------------------------------------------------
    print("labkit kinematics benchmark: PUMA 560 (6R), one core, CPU time, best of repeats")
    print(f"numpy {np.__version__}; {pin_note}")
    head = f"{'quantity':<13}{'labkit [1/s]':>14}{'target':>10}{'rtb [1/s]':>12}{'x rtb':>9}{'pinocchio':>12}{'x pin':>8}"
    print(head)
    print("-" * len(head))
    for name, r in results.items():
        lk = r["labkit"]
        rt, pn = r.get("rtb"), r.get("pinocchio")
        ok = "ok" if lk >= TARGETS[name] else "MISS"
        print(
            f"{name:<13}{lk:>14,.0f}{TARGETS[name]:>8,.0e} {ok:<2}"
            f"{(f'{rt:,.0f}' if rt else 'n/a'):>11}{(f'{lk / rt:,.0f}x' if rt else ''):>9}"
            f"{(f'{pn:,.0f}' if pn else 'n/a'):>12}{(f'{lk / pn:,.1f}x' if pn else ''):>8}"
        )
    print(f"numeric IK: {numeric_note}; analytic IK: all 8 branches per target")
    print("rtb: fkine on a trajectory, jacob0 / ikine_LM per target, ikine_a once per configuration (8)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
