"""Trajectory speed of labkit on one core: Cartesian line, via points, workspace, against peers in the same run.

Run ``python benchmarks/bench_trajectory.py`` (``--quick`` for fewer repeats).
Prints best-of-N process CPU times, the issue's targets (``ok``/``MISS``, never
asserted) and ratios to peers measured in the same run:

* 10,000-sample Cartesian line for the 3-DOF Arduino arm (seed 000's move):
  :func:`labkit.motion.cartesian_trajectory` (time law, path, IK on one
  branch, joint rates and accelerations through the Jacobian, limit check),
  and its parts; peer: roboticstoolbox-python's ``ctraj`` + ``ik_LM`` (C++,
  masked to the position) + ``jacob0`` solve per sample, timed on 200 samples
  and scaled to 10,000 (it is a per-sample loop). Target 8 ms. Before/after:
  the same line timed in fresh interpreters with labkit at ``--before REV``
  (exported with ``git archive``) and with this tree.
* via points: a 6-point PUMA 560 joint trajectory sampled 10,000 times
  (:func:`labkit.motion.via_trajectory`); peer: roboticstoolbox's ``mstraj``.
* 1,000,000-sample workspace of the arm (:func:`labkit.kinematics.workspace_points`);
  peers: the write-bandwidth floor of its output and roboticstoolbox's
  ``ETS.eval`` per sample (timed on 2,000, scaled). Target 0.15 s.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from labkit.kinematics import fk, ik, jacobian, workspace_points  # noqa: E402
from labkit.motion import cartesian_trajectory, line_path, via_trajectory  # noqa: E402
from labkit.robot import Robot  # noqa: E402
from bench_kinematics import rtb_models  # noqa: E402


def seconds(fn, repeat=7):
    """Best-of-``repeat`` process CPU time of ``fn()`` after a warm-up [s]."""
    fn()
    best = float("inf")
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return best


#: the Cartesian line, timed in a fresh interpreter by ``line_in_subprocess`` (best of ``rep`` CPU times)
LINE_CODE = """
import time, numpy as np
from labkit.robot import Robot
from labkit import motion
from labkit.motion import cartesian_trajectory
line_path = getattr(motion, "line_path", None) or motion.line  # a --before revision may predate the *_path names
arm = Robot.load("arduino_arm_3dof")
path = line_path([0.0, 0.18, -0.094], [0.1, 0.15, -0.2])
t = np.linspace(0.0, 5.0, 10_000)
run = lambda: cartesian_trajectory(arm, path, 5.0, t=t, branch="elbow_up")
run()
best = float("inf")
for _ in range({rep}):
    t0 = time.process_time()
    run()
    best = min(best, time.process_time() - t0)
print(best)
"""


def line_in_subprocess(rev, rep):
    """Seconds of the Cartesian line with labkit at git revision ``rev`` (None: this tree), or an error string.

    ``rev`` is exported with ``git archive`` into a temporary directory and
    imported from there by a fresh interpreter; this tree is timed the same
    way, so both numbers come from the same kind of process in the same run.
    """
    import io
    import subprocess
    import sys
    import tarfile
    import tempfile
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    with tempfile.TemporaryDirectory() as tmp:
        where = str(root)
        if rev is not None:
            got = subprocess.run(["git", "-C", str(root), "archive", rev, "labkit"], capture_output=True)
            if got.returncode:
                return got.stderr.decode(errors="replace").strip() or "git archive failed"
            with tarfile.open(fileobj=io.BytesIO(got.stdout)) as tar:
                tar.extractall(tmp, filter="data")
            where = tmp
        env = {**os.environ, "PYTHONPATH": where}
        done = subprocess.run([sys.executable, "-c", LINE_CODE.format(rep=rep)], env=env, capture_output=True,
                              text=True, cwd=tmp)
        if done.returncode:
            return done.stderr.strip().splitlines()[-1] if done.stderr.strip() else "failed"
        return float(done.stdout)


def row(name, t, target=None, peer=None, peer_name=""):
    tg = "" if target is None else f"target {target * 1e3:7.1f} ms {'ok' if t <= target else 'MISS':<4}"
    pr = "" if peer is None else f"{peer_name} {peer * 1e3:9.1f} ms  labkit/peer {t / peer:6.3f}"
    print(f"{name:<52s}{t * 1e3:9.2f} ms  {tg:<24s}{pr}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats")
    ap.add_argument("--before", default="7998dd6", metavar="REV",
                    help="git revision timed as 'before' for the Cartesian line (default 7998dd6, the tree "
                         "before the compiled Jacobian programs, the one-branch IK path and the lean joint "
                         "rates of issue 15); '' to skip")
    args = ap.parse_args(argv)
    rep = 3 if args.quick else 7
    import labkit

    print(f"labkit trajectory benchmark (labkit from {os.path.dirname(labkit.__file__)}); numpy {np.__version__};"
          " one core, process CPU time, best of repeats")
    arm = Robot.load("arduino_arm_3dof")
    peers = rtb_models(arm)

    # -- Cartesian line -----------------------------------------------------------------
    path = line_path([0.0, 0.18, -0.094], [0.1, 0.15, -0.2])
    t = np.linspace(0.0, 5.0, 10_000)
    traj = cartesian_trajectory(arm, path, 5.0, t=t, branch="elbow_up")
    assert traj.q.shape == (10_000, 3)
    full = seconds(lambda: cartesian_trajectory(arm, path, 5.0, t=t, branch="elbow_up"), rep)
    peer = None
    if peers:
        ets = peers[1]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import roboticstoolbox as rtb
            from spatialmath import SE3

        m = 200
        T0, T1 = SE3(fk(arm, traj.q[0]), check=False), SE3(fk(arm, traj.q[-1]), check=False)
        mask = np.array([1.0, 1, 1, 0, 0, 0])
        xd = np.gradient(traj.x[:m], t[:m], axis=0)

        def rtb_line():
            poses = rtb.ctraj(T0, T1, m)
            q = np.array(traj.q[0])  # a writeable copy (the trajectory is read-only)
            for k in range(m):
                q = ets.ik_LM(poses[k].A, q0=q, tol=1e-10, mask=mask).q
                np.linalg.lstsq(ets.jacob0(q)[:3], xd[k], rcond=None)

        peer = seconds(rtb_line, 2) * (len(t) / m)
    print(f"\nCartesian line, {len(t):,} samples, 3-DOF arm (peer rtb: ctraj + ik_LM + jacob0 per sample,"
          f" scaled from 200 samples)")
    row("cartesian_trajectory: time law, path, IK, qd, qdd", full, 0.008, peer, "rtb")
    row("  of which IK (one branch) on the 10,000 points", seconds(lambda: ik(arm, traj.x, branch="elbow_up"), rep))
    row("  of which Jacobians on the 10,000 configurations", seconds(lambda: jacobian(arm, traj.q), rep))
    if args.before:
        before, after = line_in_subprocess(args.before, rep), line_in_subprocess(None, rep)
        if isinstance(before, float) and isinstance(after, float):
            print(f"  before/after, fresh interpreters in this run: labkit at {args.before} {before * 1e3:.2f} ms, "
                  f"this tree {after * 1e3:.2f} ms ({before / after:.2f}x faster); "
                  f"target 8.0 ms: {'ok' if after <= 0.008 else 'MISS'}")
        else:
            print(f"  before/after: n/a ({before if not isinstance(before, float) else after})")

    # -- via points ------------------------------------------------------------------------
    puma = Robot.load("puma560")
    rng = np.random.default_rng(5)
    lim = puma.joint_limits
    pts = rng.uniform(0.5 * lim[:, 0], 0.5 * lim[:, 1], size=(6, 6))
    tv = np.linspace(0.0, 5.0, 10_000)
    lab = seconds(lambda: via_trajectory(puma, pts, durations=1.0, t=tv), rep)
    peer = None
    if peers:
        peer = seconds(lambda: rtb.mstraj(pts, dt=5.0 / 10_000, tacc=0.2, tsegment=[1.0] * 5), 3)
    print("\nvia points: 6 PUMA 560 configurations, 10,000 samples (peer rtb: mstraj, same segments)")
    row("via_trajectory (via cubic)", lab, None, peer, "rtb")

    # -- workspace ----------------------------------------------------------------------------
    N = 1_000_000
    ws = seconds(lambda: workspace_points(arm, n=N), max(2, rep // 2))
    floor = seconds(lambda: np.empty((N, 3)).fill(0.0), 3)
    peer = None
    if peers:
        q = workspace_points(arm, n=2000).q
        peer = seconds(lambda: [ets.eval(qk) for qk in q], 2) * (N / 2000)
    print(f"\nworkspace, {N:,} samples, 3-DOF arm (floor: allocate + write the (N, 3) output;"
          " peer rtb: ETS.eval per sample, scaled from 2,000)")
    row("workspace_points", ws, 0.15, peer, "rtb")
    row("  write-bandwidth floor of the output", floor)
    print(f"  labkit / floor = {ws / floor:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
