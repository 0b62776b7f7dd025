"""Kinematics speed of labkit on one core, against compiled peers measured in the same run.

Run::

    python benchmarks/bench_kinematics.py            # full run (about a minute)
    python benchmarks/bench_kinematics.py --quick    # smaller batches and repeats

Peers (each when importable; ``pip install -e '.[bench]'``): roboticstoolbox-python
(the Python DH model and the ETS C backend: ``ETS.eval``/``fkine``,
``jacob0``, ``ik_LM`` in C++), pinocchio (built from the same DH rows), and a
numba-jitted DH chain (``benchmarks/_numba_chain.py``). Prints

1. single calls on the 3-DOF Arduino arm and the PUMA 560 [us per call];
2. batched FK and Jacobian of the PUMA 560 for batches of 1, 10, 1000 and
   100k [configurations/s], with the write-bandwidth floor of the output
   (allocating and filling an array of the output's size) and the ratio to the
   numba chain; the Jacobian also through a generic numpy block walk
   (``benchmarks/_numpy_walk.py``: what labkit ran before the compiled
   per-robot programs, same run);
3. numeric IK of the PUMA 560 (in-limit random targets, tolerance 1e-10):
   ms per target one by one, targets/s at batch 1000, success rate, against
   ``ik_LM`` (C++) one target at a time (for the PUMA with a 2 mm offset a5,
   labkit's and ``ik_LM``'s passes over the same targets take turns);
4. the peak memory of a 1M-configuration Jacobian against its output;
5. start-up: ``import labkit, labkit.kinematics`` and ``labkit --help`` (wall
   time of a fresh interpreter, beside a bare one and ``import numpy``);
6. cold first calls: ``fk``, ``jacobian``, ``ik`` and ``ik_numeric`` on a
   freshly loaded robot (3-DOF arm, PUMA 560, the PUMA with a5 = 2 mm), in a
   fresh interpreter (nothing compiled yet) and after other robots of the
   same structure were used [ms];
7. ``measure.calibrate`` on seed 000's FK tables (joint offsets and link
   lengths, leave-one-out) [ms].

Times are process CPU time, best of several repeats (other jobs on a shared
machine do not inflate them); threads are pinned to one. The issue's targets
are printed with ``ok``/``MISS``, never asserted.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from labkit.kinematics import fk, ik, ik_all, ik_numeric, jacobian  # noqa: E402
from labkit.robot import Convention, Robot  # noqa: E402


#: seconds one timing aims at when the number of calls is chosen automatically (--smoke: less)
BUDGET = [0.05]


def seconds(func, number=None, repeat=5):
    """Best-of-``repeat`` process CPU time of one ``func()`` call, averaged over ``number`` calls [s].

    ``number=None`` picks enough calls for a timing of about ``BUDGET`` seconds (from the warm-up call).
    """
    t0 = time.process_time()
    func()  # warm-up: imports, caches, JIT
    first = time.process_time() - t0
    if number is None:
        number = min(100_000, max(1, int(BUDGET[0] / max(first, 1e-7))))
    number = max(1, int(number))
    best = float("inf")
    for _ in range(repeat):
        t0 = time.process_time()
        for _ in range(number):
            func()
        best = min(best, (time.process_time() - t0) / number)
    return max(best, 1e-9)  # a process-clock tick can read as 0 for a tiny smoke run


def paired_seconds(funcs, repeat=5):
    """Best-of-``repeat`` process CPU time of one call of each of ``funcs``, the calls taking turns [s].

    Each round calls every function once, so a slow phase of a shared machine
    (minutes long on a virtual one) falls on all of them, not on one: their
    ratio is steadier than from two :func:`seconds` runs one after the other.
    """
    for func in funcs:
        func()  # warm-up
    best = [float("inf")] * len(funcs)
    for _ in range(repeat):
        for i, func in enumerate(funcs):
            t0 = time.process_time()
            func()
            best[i] = min(best[i], time.process_time() - t0)
    return [max(b, 1e-9) for b in best]


# -- peers ------------------------------------------------------------------------------

def rtb_models(robot):
    """roboticstoolbox-python's DH model of ``robot`` and its ETS (C backend), or None."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import roboticstoolbox as rtb
            from spatialmath import SE3
    except ImportError:
        return None
    links = []
    for lk in robot.links:
        kw = dict(a=lk.a, alpha=lk.alpha, qlim=list(lk.limits))
        if robot.convention is Convention.STANDARD:
            cls = rtb.RevoluteDH if lk.is_revolute else rtb.PrismaticDH
        else:
            cls = rtb.RevoluteMDH if lk.is_revolute else rtb.PrismaticMDH
        kw.update(d=lk.d, offset=lk.theta) if lk.is_revolute else kw.update(theta=lk.theta, offset=lk.d)
        links.append(cls(**kw))
    dh = rtb.DHRobot(links, name=robot.name, base=SE3(robot.base, check=False), tool=SE3(robot.tool, check=False))
    return dh, dh.ets()


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


def numba_chain(robot):
    """(fk, jacobian) of the numba reference for ``robot``, compiled, or None."""
    try:
        import _numba_chain as nc
    except ImportError:
        return None
    consts = nc.constants(robot)
    n = robot.n

    def fk_nb(q):
        return nc.fk(q, *consts, np.empty((q.shape[0], 4, 4)))

    def jac_nb(q):
        return nc.jacobian(q, *consts, np.empty((q.shape[0], 6, n)))

    q = np.zeros((2, n))
    fk_nb(q), jac_nb(q)  # compile
    return fk_nb, jac_nb


# -- report helpers -----------------------------------------------------------------------

def verdict(ok):
    return "ok" if ok else "MISS"


def fmt_rate(r):
    return "n/a" if r is None else (f"{r / 1e6:.2f}M" if r >= 1e6 else f"{r / 1e3:.1f}k" if r >= 1e3 else f"{r:.0f}")


def single_calls(args):
    print("\n1. single calls [us per call]; ratio = labkit / peer (<= 1.0 is as fast or faster)")
    arm = Robot.load("arduino_arm_3dof")
    puma = Robot.load("puma560")
    q3 = np.radians([45.0, 60.0, 30.0])
    target = fk(arm, q3)[:3, 3]
    q6 = np.array([0.1, 0.5, -0.3, 0.2, 0.4, 0.1])
    rows = []
    for name, robot, q in (("3-DOF arm", arm, q3), ("PUMA 560", puma, q6)):
        peers = rtb_models(robot)
        ets = peers[1] if peers else None
        pm = pinocchio_model(robot)
        T = fk(robot, q)
        r = {}
        r["fk"] = (seconds(lambda: fk(robot, q), None),
                   seconds(lambda: ets.fkine(q), None) if ets else None,
                   seconds(lambda: ets.eval(q), None) if ets else None)
        r["jacobian"] = (seconds(lambda: jacobian(robot, q), None),
                         seconds(lambda: ets.jacob0(q), None) if ets else None, None)
        if pm:
            pin, model, data, fid = pm
            r["fk"] += (seconds(lambda: (pin.framesForwardKinematics(model, data, q), data.oMf[fid].homogeneous), None),)
            r["jacobian"] += (seconds(lambda: pin.computeFrameJacobian(
                model, data, q, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED), None),)
        tgt = target if robot is arm else T
        mask = np.array([1.0, 1, 1, 0, 0, 0]) if robot is arm else None  # the arm's target is a position
        lm = (lambda: ets.ik_LM(T, tol=1e-10, mask=mask)) if ets else None
        if robot is arm:
            r["ik one branch"] = (seconds(lambda: ik(robot, tgt, branch="elbow_up"), None),
                                  seconds(lm, None) if ets else None, None)
            r["ik_all"] = (seconds(lambda: ik_all(robot, tgt), None), None, None)
            # one target is a batch of one: the rows that once forced the batched path time the same call
            r["ik 1 br. batched"] = (seconds(lambda: ik(robot, tgt[None], branch="elbow_up"), None),
                                     seconds(lm, None) if ets else None, None)
            r["ik_all batched"] = (seconds(lambda: ik_all(robot, tgt[None]), None), None, None)
        else:
            r["ik one branch"] = (seconds(lambda: ik(robot, tgt), None),
                                  seconds(lm, None) if ets else None, None)
            r["ik_all (8)"] = (seconds(lambda: ik_all(robot, tgt), None), None, None)
            r["ik batched"] = (seconds(lambda: ik(robot, tgt[None]), None), seconds(lm, None) if ets else None, None)
            r["ik_all batched"] = (seconds(lambda: ik_all(robot, tgt[None]), None), None, None)
        rows.append((name, r))
    targets = {("3-DOF arm", "fk"): 25, ("3-DOF arm", "jacobian"): 40, ("3-DOF arm", "ik one branch"): 40,
               ("3-DOF arm", "ik_all"): 60, ("PUMA 560", "fk"): 40}
    head = (f"{'robot':<11}{'call':<15}{'labkit':>9}{'target':>8}  {'rtb C':>8}{'ratio':>7}"
            f"{'rtb eval':>10}{'pin':>8}{'ratio':>7}")
    print(head)
    print("-" * len(head))
    for name, r in rows:
        for call, vals in r.items():
            lk, rt, ev = (v * 1e6 if v else None for v in vals[:3])
            pn = vals[3] * 1e6 if len(vals) > 3 and vals[3] else None
            tg = targets.get((name, call))
            tgs = f"{tg:>5d} {verdict(lk <= tg):<4}" if tg else " " * 10
            print(f"{name:<11}{call:<15}{lk:>9.1f}{tgs:>10}"
                  f"{(f'{rt:.1f}' if rt else 'n/a'):>8}{(f'{lk / rt:.2f}' if rt else ''):>7}"
                  f"{(f'{ev:.1f}' if ev else ''):>10}{(f'{pn:.1f}' if pn else ''):>8}{(f'{lk / pn:.2f}' if pn else ''):>7}")
    print("rtb C: ETS.fkine / jacob0 / ik_LM (C++, tol 1e-10; for the 3-DOF arm masked to the position);"
          " rtb eval: ETS.eval (no SE3 wrapper); pin: pinocchio frame placement / frame Jacobian;"
          " 'batched': the target as a batch of one (one path for one target and a batch)")


def floor_rate(shape_tail, N, args):
    """Configurations/s at which this machine can allocate and write an output of ``shape_tail`` each."""
    t = seconds(lambda: np.empty((N,) + shape_tail).fill(0.0), 1, 3 if args.quick else 5)
    return N / t


def batched(args):
    print("\n2. batched PUMA 560 [configurations/s, CPU time]; x numba = labkit / numba chain")
    puma = Robot.load("puma560")
    lim = puma.joint_limits
    rng = np.random.default_rng(2026)
    batches = (1, 10, 1000) if args.smoke else (1, 10, 1000, 20_000 if args.quick else 100_000)
    Q = rng.uniform(lim[:, 0], lim[:, 1], size=(batches[-1], 6))
    peers = rtb_models(puma)
    nb = numba_chain(puma)
    pm = pinocchio_model(puma)
    check = []
    if nb:
        check.append(np.abs(nb[0](Q[:100]) - fk(puma, Q[:100])).max())
        check.append(np.abs(nb[1](Q[:100]) - jacobian(puma, Q[:100])).max())
    if peers:
        dh, ets = peers
        check.append(max(np.abs(ets.eval(q) - fk(puma, q)).max() for q in Q[:20]))
        check.append(max(np.abs(ets.jacob0(q) - jacobian(puma, q)).max() for q in Q[:20]))
    print(f"max |difference| of the peers' results to labkit: {max(check) if check else float('nan'):.1e}")
    rep = 1 if args.smoke else 3 if args.quick else 5
    head = (f"{'quantity':<10}{'batch':>8}{'labkit':>9}{'numba':>9}{'x numba':>9}{'rtb C':>9}{'rtb DH':>9}"
            f"{'pin':>9}{'floor':>9}{'% floor':>9}")
    print(head)
    print("-" * len(head))
    summary = {}
    for quantity, lk_func, tail in (("FK", fk, (4, 4)), ("Jacobian", jacobian, (6, 6))):
        for N in batches:
            q = Q[:N]
            lk = N / seconds(lambda: lk_func(puma, q), None, rep)
            nbr = N / seconds(lambda: nb[0 if quantity == "FK" else 1](q), None, rep) if nb else None
            m = min(N, 2000)
            rtc = rtd = pn = None
            if peers:
                dh, ets = peers
                one = ets.eval if quantity == "FK" else ets.jacob0
                rtc = m / seconds(lambda: [one(qk) for qk in q[:m]], 1, 2)
                md = min(N, 200)
                rtd = md / seconds((lambda: dh.fkine(q[:md])) if quantity == "FK"
                                   else (lambda: [dh.jacob0(qk) for qk in q[:md]]), 1, 2)
            if pm:
                pin, model, data, fid = pm
                if quantity == "FK":
                    def run():
                        for qk in q[:m]:
                            pin.framesForwardKinematics(model, data, qk)
                            data.oMf[fid].homogeneous
                else:
                    def run():
                        for qk in q[:m]:
                            pin.computeFrameJacobian(model, data, qk, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
                pn = m / seconds(run, 1, 2)
            fl = floor_rate(tail, N, args) if N >= 1000 else None
            print(f"{quantity:<10}{N:>8,}{fmt_rate(lk):>9}{fmt_rate(nbr):>9}{(f'{lk / nbr:.2f}x' if nbr else ''):>9}"
                  f"{fmt_rate(rtc):>9}{fmt_rate(rtd):>9}{fmt_rate(pn):>9}{fmt_rate(fl):>9}"
                  f"{(f'{100 * lk / fl:.1f}' if fl else ''):>9}")
            summary[quantity, N] = (lk, nbr)
    # analytic IK: all 8 branches of the spherical-wrist solver against rtb's ikine_a (one branch per call)
    T = fk(puma, Q)
    n_ik = min(batches[-1], 20_000)
    lk = n_ik / seconds(lambda: ik_all(puma, T[:n_ik]), 1, rep)
    rta = None
    if peers:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import roboticstoolbox as rtb

            ref = rtb.models.DH.Puma560()  # the model labkit's puma560.toml reproduces; it has ikine_a
            m = 10 if args.smoke else 100
            rta = m / seconds(lambda: [ref.ikine_a(T[k], config=cf) for k in range(m)
                                       for cf in ("lun", "luf", "ldn", "ldf", "run", "ruf", "rdn", "rdf")], 1, 2)
    print(f"{'analytic IK':<12}{n_ik:>6,}{fmt_rate(lk):>9} targets/s (all 8 branches); rtb ikine_a x8: "
          f"{fmt_rate(rta)} targets/s; {(f'{lk / rta:,.0f}x' if rta else '')}")
    big = batches[-1]
    # before/after of the compiled Jacobian programs: the same Jacobians by a generic block walk
    import _numpy_walk

    for N in batches[-2:]:
        before = N / seconds(lambda: _numpy_walk.jacobian(puma, Q[:N]), None, rep)
        after, nbr = summary["Jacobian", N]
        print(f"Jacobian {N:>8,}: before (generic walk) {fmt_rate(before)}"
              f"{(f' = {before / nbr:.2f}x numba' if nbr else '')}, after (compiled program) {fmt_rate(after)}"
              f"{(f' = {after / nbr:.2f}x numba' if nbr else '')}: {after / before:.2f}x faster")
    for quantity in ("FK", "Jacobian"):
        lk, nbr = summary[quantity, big]
        if nbr:
            print(f"target: batched {quantity} at {big:,} >= 1.0x the numba chain: {lk / nbr:.2f}x "
                  f"{verdict(lk >= nbr)}")
    print("floor: allocate + write an output array of the same size (memory bandwidth incl. page faults);"
          " rtb/pin: one call per configuration in a Python loop (rtb DH: fkine on up to 200)")


def numeric_ik(args):
    print("\n3. numeric IK, PUMA 560, in-limit random targets, tolerance 1e-10")
    puma = Robot.load("puma560")
    lim = puma.joint_limits
    rng = np.random.default_rng(7)
    n1 = 5 if args.smoke else 20 if args.quick else 100
    nb = 50 if args.smoke else 200 if args.quick else 1000
    T = fk(puma, rng.uniform(lim[:, 0], lim[:, 1], size=(nb, 6)))
    res = [ik_numeric(puma, T[k], tol=1e-10) for k in range(n1)]
    one = seconds(lambda: [ik_numeric(puma, T[k], tol=1e-10) for k in range(n1)], 1, 2) / n1
    ok1 = np.mean([r.success for r in res])
    resb = ik_numeric(puma, T, tol=1e-10)
    batch = nb / seconds(lambda: ik_numeric(puma, T, tol=1e-10), 1, 2)
    peers = rtb_models(puma)
    lm = lm_ok = None
    if peers:
        ets = peers[1]
        m = 10 if args.smoke else 50 if args.quick else 200
        sols = [ets.ik_LM(T[k], tol=1e-10) for k in range(m)]
        lm_ok = np.mean([s.success for s in sols])
        lm = m / seconds(lambda: [ets.ik_LM(T[k], tol=1e-10) for k in range(m)], 1, 2)
    print(f"batch 1:     {one * 1e3:7.3f} ms per target  (target <= 1 ms: {verdict(one <= 1e-3)}), "
          f"success {ok1:.1%}, mean iterations {np.mean([r.iterations for r in res]):.1f}")
    print(f"batch {nb}:  {batch:9,.0f} targets/s  success {resb.success.mean():.1%}, "
          f"max residual {resb.residual.max():.1e}, mean iterations {resb.iterations.mean():.1f}")
    if lm:
        print(f"rtb ik_LM (C++, one by one): {lm:9,.0f} targets/s, success {lm_ok:.1%}; "
              f"labkit batch {nb} / ik_LM = {batch / lm:.2f}x (target >= 2x: {verdict(batch >= 2 * lm)}); "
              f"labkit batch 1 / ik_LM = {(1 / one) / lm:.2f}x")
    print("(the PUMA 560 has a closed form: the LM starts from the analytic solution and only polishes it)")
    # the same arm with a 2 mm offset a5: no closed form; LM starts from the closed form of its idealised copy (a5 = 0)
    bent = puma.with_link(4, a=0.002)
    Tb = fk(bent, rng.uniform(lim[:, 0], lim[:, 1], size=(nb, 6)))
    res = [ik_numeric(bent, Tb[k], tol=1e-10) for k in range(n1)]
    ets_b = rtb_models(bent)[1] if peers else None
    rounds = 2 if args.smoke else 7

    def labkit_one():
        return [ik_numeric(bent, Tb[k], tol=1e-10) for k in range(n1)]

    if ets_b:  # one target at a time, on the same targets, labkit and ik_LM taking turns in the same run
        one, same = (t / n1 for t in paired_seconds(
            [labkit_one, lambda: [ets_b.ik_LM(Tb[k], tol=1e-10) for k in range(n1)]], rounds))
    else:
        one = seconds(labkit_one, 1, rounds) / n1
    resb = ik_numeric(bent, Tb, tol=1e-10)
    batch = nb / seconds(lambda: ik_numeric(bent, Tb, tol=1e-10), 1, 2)
    lm = None
    if peers:
        m = 10 if args.smoke else 50 if args.quick else 200
        sols = [ets_b.ik_LM(Tb[k], tol=1e-10) for k in range(m)]
        lm_ok = np.mean([s.success for s in sols])
        lm_it = np.mean([s.iterations for s in sols])
        lm_res = max(float(s.residual) for s in sols)
        lm = m / seconds(lambda: [ets_b.ik_LM(Tb[k], tol=1e-10) for k in range(m)], 1, 2)
    print("PUMA 560 with a5 = 2 mm (no closed form; LM from the branches of its idealised copy, a5 = 0):")
    print(f"batch 1:     {one * 1e3:7.3f} ms per target  (target <= 1 ms: {verdict(one <= 1e-3)}), "
          f"success {np.mean([r.success for r in res]):.1%}, mean iterations {np.mean([r.iterations for r in res]):.1f}")
    print(f"batch {nb}:  {batch:9,.0f} targets/s  success {resb.success.mean():.1%}, "
          f"max residual {resb.residual.max():.1e}, mean iterations {resb.iterations.mean():.1f}")
    if lm:
        print(f"rtb ik_LM (C++, one by one): {lm:9,.0f} targets/s, success {lm_ok:.1%}; "
              f"labkit batch {nb} / ik_LM = {batch / lm:.2f}x (target >= 2x: {verdict(batch >= 2 * lm)}); "
              f"labkit batch 1 / ik_LM = {(1 / one) / lm:.2f}x")
        print(f"rtb ik_LM on the first {m} targets: mean iterations {lm_it:.1f}, max residual {lm_res:.1e} "
              f"(its own measure: E = e^T W e)")
        print(f"one target (same {n1} targets, taking turns): labkit {one * 1e3:.3f} ms, ik_LM {same * 1e3:.3f} ms: "
              f"{one / same:.2f}x slower (for information: issue 35 retired this ratio as a goal; the goal is "
              f"<= 1 ms a target: {verdict(one <= 1e-3)})")
        # ik_LM's tol bounds its own E (half the squared error): at 1e-10 its solutions miss by up to ~1e-5 m,
        # labkit's by at most 1e-10 (its tol bounds the residual); for information, ik_LM to labkit's accuracy
        tight = 5e-21
        _, res_t = _targets_error(bent, np.array([ets_b.ik_LM(Tb[k], tol=tight).q for k in range(n1)]), Tb[:n1])
        _, res_d = _targets_error(bent, np.array([ets_b.ik_LM(Tb[k], tol=1e-10).q for k in range(n1)]), Tb[:n1])
        one_t, same_t = (t / n1 for t in paired_seconds(
            [labkit_one, lambda: [ets_b.ik_LM(Tb[k], tol=tight) for k in range(n1)]], rounds))
        print(f"  (information) labkit's residual of ik_LM's solutions: up to {res_d.max():.1e} at tol 1e-10, "
              f"{res_t.max():.1e} at tol {tight:g}; at that equal accuracy ik_LM takes {same_t * 1e3:.3f} ms, "
              f"labkit {one_t * 1e3:.3f} ms: {one_t / same_t:.2f}x")


def _targets_error(robot, q, target):
    """labkit's task error and residual of configurations ``q`` (N, n) against pose targets (N, 4, 4)."""
    from labkit.kinematics._ik_solvers._lm import task_error

    return task_error("pose", fk(robot, q), target, tuple(range(6)))


def peak_memory(args):
    N = 20_000 if args.smoke else 200_000 if args.quick else 1_000_000
    puma = Robot.load("puma560")
    q = np.random.default_rng(3).uniform(-1, 1, size=(N, 6))
    tracemalloc.start()
    J = jacobian(puma, q)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    ratio = peak / J.nbytes
    print(f"\n4. Jacobian of {N:,} configurations: peak {peak / 2**20:.0f} MiB for an output of "
          f"{J.nbytes / 2**20:.0f} MiB = {ratio:.3f}x (target <= 1.1x: {verdict(ratio <= 1.1)})")


def startup(args):
    import subprocess
    import sys

    def wall(code, repeat=1 if args.smoke else 5):
        best = float("inf")
        for _ in range(repeat):
            t0 = time.perf_counter()
            subprocess.run([sys.executable, *code], check=True, capture_output=True)
            best = min(best, time.perf_counter() - t0)
        return best

    bare = wall(["-c", "pass"])
    npy = wall(["-c", "import numpy"])
    kin = wall(["-c", "import labkit, labkit.kinematics"])
    cli = wall(["-m", "labkit", "--help"])
    print(f"\n5. start-up, wall time of a fresh interpreter (best of {1 if args.smoke else 5}): bare python {bare:.3f} s, "
          f"import numpy {npy:.3f} s")
    print(f"import labkit, labkit.kinematics {kin:.3f} s (target <= 0.25 s: {verdict(kin <= 0.25)}); "
          f"labkit --help {cli:.3f} s (target <= 0.3 s: {verdict(cli <= 0.3)})")


#: the cold calls, run in a fresh interpreter: ``first`` (nothing used before) or ``again`` (robots of the same
#: structures used once, then loaded afresh); prints one line per robot: name and ms per call
_COLD = """
import sys, time
import numpy as np
from labkit.kinematics import fk, jacobian, ik, ik_numeric
from labkit.robot import Robot

def robots():
    puma = Robot.load("puma560")
    return [("3-DOF arm", Robot.load("arduino_arm_3dof")), ("PUMA 560", puma), ("bent PUMA", puma.with_link(4, a=0.002))]

def once(robot):
    q, out = np.full(robot.n, 0.3), []
    for call in (lambda: fk(robot, q), lambda: jacobian(robot, q), lambda: ik(robot, target),
                 lambda: ik_numeric(robot, target)):
        t0 = time.process_time()
        T = call()
        out.append(time.process_time() - t0)
        if len(out) == 1:
            target = T[:3, 3] if robot.n == 3 else T
    return out

if sys.argv[1] == "again":
    for _, robot in robots():
        once(robot)
for name, robot in robots():
    print(name, *once(robot))
"""


def cold(args):
    import subprocess
    import sys

    print("\n6. cold first calls on a freshly loaded robot [ms, CPU time; target <= 5 ms each]")
    calls = ("fk", "jacobian", "ik", "ik_numeric")
    print(f"{'':<28}" + "".join(f"{c:>12}" for c in calls))
    repeat = 1 if args.smoke else 3
    for mode, words in (("first", "fresh interpreter"), ("again", "same structure used before")):
        best = {}
        for _ in range(repeat):
            out = subprocess.run([sys.executable, "-c", _COLD, mode], check=True, capture_output=True, text=True).stdout
            for line in out.splitlines():
                name, *vals = line.rsplit(" ", 4)
                best[name] = [min(a, float(b)) for a, b in zip(best.get(name, [np.inf] * 4), vals)]
        for name, vals in best.items():
            print(f"{name + ', ' + words:<28}" + "".join(f"{v * 1e3:>8.2f} {verdict(v <= 5e-3):<3}" for v in vals))


def calibration(args):
    from labkit.data import measurement_file
    from labkit.measure import calibrate

    arm = Robot.load("arduino_arm_3dof")
    path = measurement_file("seed000_fk_tables1-3.csv")
    t = seconds(lambda: calibrate(arm, path, params=("joint_offsets", "link_lengths")), 1, 1 if args.smoke else 3)
    print(f"\n7. calibrate, seed 000's FK tables (joint offsets and link lengths, leave-one-out): {t * 1e3:.0f} ms")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller batches and repeats")
    ap.add_argument("--smoke", action="store_true",
                    help="tiny batches, one repeat: checks that every row prints (the test suite runs this)")
    ap.add_argument("--only", choices=("single", "batched", "ik", "memory", "startup", "cold", "calibrate"),
                    help="run one section")
    args = ap.parse_args(argv)
    args.quick = args.quick or args.smoke
    if args.smoke:
        BUDGET[0] = 0.002
    import labkit

    print(f"labkit kinematics benchmark (labkit from {os.path.dirname(labkit.__file__)}); numpy {np.__version__}; "
          "one core, process CPU time, best of repeats")
    sections = {"single": single_calls, "batched": batched, "ik": numeric_ik, "memory": peak_memory,
                "startup": startup, "cold": cold, "calibrate": calibration}
    for name, func in sections.items():
        if args.only in (None, name):
            func(args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
